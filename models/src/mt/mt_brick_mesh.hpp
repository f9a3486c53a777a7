#pragma once
// The mesh one pass of the MT build hands to the next (docs/mt.md §2, "Bricks"), packed
// into bytes. Between passes it is the largest thing the build holds (after pass 0 of
// a 257³ volume, tens of millions of tets, all of them waiting for the bricks of pass 1),
// and as plain arrays it took 40 B per tet and 4 B per owned point. Packed, a tet's
// vertices and points are small offsets from its first vertex, and its errors, which
// are often zero or repeat the largest face error, are stored only when they say
// something. Packing is lossless: every float keeps its bits, every list its order.
//
// One record per tet, position independent (records move between meshes as bytes):
//   v0                        varint
//   v1 - v0, v2 - v0, v3 - v0 zigzag varints
//   flags                     1 byte: bit k (0..3) face error k is stored; bit 4 err is
//                             stored (else it equals the largest stored face error, or 0)
//   face errors, err          4 bytes each (little-endian float bits), those flagged
//   count                     varint: the points the tet owns
//   p - v0 per point          zigzag varints, in list order
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tetlod::mt {

/// The fixed part of a handed-over tet: whole-grid vertex indices (positively
/// oriented), closed error, error of the face opposite each corner, owned points.
struct HandedTet {
    std::array<uint32_t, 4> v{};
    float err = 0;
    std::array<float, 4> face_err{0, 0, 0, 0};
    uint32_t points = 0;
};

/// A brick's decimated mesh: its tets in a deterministic order, each with the removed
/// grid points it owns (whole-grid indices, in list order).
struct BrickMesh {
    std::vector<uint8_t> bytes;
    size_t tets = 0;    // records in `bytes`
    size_t points = 0;  // owned points over all records

    /// Bytes the record of `t` with `points` takes (to size a mesh before filling it).
    static size_t record_size(const HandedTet& t, const uint32_t* points);
    /// Appends a record; `t.points` points follow in `points`.
    void append(const HandedTet& t, const uint32_t* points);
    /// Appends the record that takes bytes [begin, end) of `from`, owning `points` points.
    void append_record(const BrickMesh& from, size_t begin, size_t end, uint32_t points);
};

/// Reads a mesh's records in order: next() the fixed part, then point() exactly
/// `points` times (or skip_points()).
class BrickMeshReader {
public:
    explicit BrickMeshReader(const BrickMesh& m) : m_(m) {}
    /// False at the end.
    bool next(HandedTet& t);
    uint32_t point();
    void skip_points();
    /// Byte offsets of the current record: where it starts, and how far it has been read.
    size_t record_begin() const { return begin_; }
    size_t offset() const { return at_; }

private:
    uint32_t varint();
    const BrickMesh& m_;
    size_t at_ = 0, begin_ = 0;
    uint32_t v0_ = 0, left_ = 0;
};

}  // namespace tetlod::mt
