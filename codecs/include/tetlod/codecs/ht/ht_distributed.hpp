#pragma once
// Hooks for an HT conversion spread over processes (tetlod-mpi,
// docs/distributed.md §3.6): each process runs the two expensive parts of
// write_ht_container_streaming's passes over its own range of planes of the
// data box B, and the results combine into exactly what one process computes.
//
//  1. ht_scan_planes over za..zb: the value range, finiteness and the coarse
//     lattice points of those planes; ht_merge_scan folds the parts in plane
//     order (the same floats as the serial scan).
//  2. HtRangeErrors over za..zb: the errors of the diamonds centred there.
//     Diamonds small enough to lie in za - kReach .. zb + kReach are final at
//     once; larger ones are partial maxima over the rows of za..zb, merged
//     over all processes (a maximum of partial maxima is exact in any
//     grouping), then finish() writes their errors.
//  3. Every process encodes the rows of bricks starting in its planes
//     (ht_rows_in, HtRowEncoder) from the lattice planes of each row's window
//     (ht_row_window; values from ht_lattice_values, errors from the owner
//     of each plane), and the sections' sizes and checksums go to one
//     process, which lays out the file (ht_distributed_layout): the bytes at
//     offset 0 and every section's offset; each process writes its sections
//     there. Or (step 2): one process encodes, passing an HtErrorSource to the encoder
//     (HtStreamEncodeOptions::errors) that serves those errors, for instance
//     packed (ht_pack_errors) and sent by their owners.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/core/volume_planes.hpp"
#include "tetlod/format/metadata.hpp"
#include "tetlod/models/ht/ht_error_sweep.hpp"

namespace tetlod {

/// Source planes (clamped to the volume) that planes za..zb of B need for
/// their errors: the planes themselves and HtErrorSweep::kReach on each side.
std::array<int64_t, 2> ht_source_planes_for(const HtDomain& domain, const Dims& source, int64_t za, int64_t zb);

struct HtScanPart {
    bool any = false;                    // some source sample lies in the planes
    std::array<double, 2> range{0, 0};   // their extremes (when any)
    std::vector<std::byte> coarse;       // the coarse lattice; zero outside the planes
};
/// Pass 1 over planes za..zb of B (za > zb: none). `source` serves the source
/// planes ht_source_planes_for(za, zb) (planes outside are not read). Throws
/// CorruptData at the first non-finite sample, as the serial scan does.
HtScanPart ht_scan_planes(VolumePlanes& source, bool pad, int64_t za, int64_t zb);
/// Folds `next` (planes after those of `into`) into `into`: the serial scan's
/// result when every part is folded in plane order.
void ht_merge_scan(HtScanPart& into, const HtScanPart& next);

/// The errors of the diamonds centred in planes za..zb of B (every cycle t < k).
class HtRangeErrors final : public HtErrorPlaneSink {
public:
    HtRangeErrors(VolumePlanes& source, bool pad, std::array<double, 2> range, std::vector<std::byte> coarse,
                  int64_t za, int64_t zb, int64_t slab_planes = 64);
    ~HtRangeErrors() override;
    /// Sweeps the planes (reads ht_source_planes_for(za, zb) from the source).
    void compute();
    /// The large diamonds' running maxima: merge those of every process, then finish().
    std::vector<std::byte> partial_maxima() const { return sweep_.partial_maxima(); }
    void merge_partial_maxima(const std::byte* other, std::size_t bytes) { sweep_.merge_partial_maxima(other, bytes); }
    /// For a reduction (MPI_Allreduce with a user operation): see HtErrorSweep::merge_maxima.
    std::size_t partial_maximum_bytes() const { return sweep_.partial_maximum_bytes(); }
    void merge_maxima(const std::byte* in, std::byte* inout, std::size_t bytes) const {
        sweep_.merge_maxima(in, inout, bytes);
    }
    void finish();

    const HtDomain& domain() const { return d_; }
    int64_t za() const { return za_; }
    int64_t zb() const { return zb_; }
    /// Packs the errors centred in planes z1..z2 (inside za..zb): see ht_pack_errors.
    void pack(int64_t z1, int64_t z2, float* out) const;
    /// Bytes held (the error planes).
    std::size_t bytes() const;

    float* error_plane(int t, int64_t z) override;

private:
    VolumePlanes& source_;
    HtDomain d_;
    int64_t za_, zb_, slab_;
    HtErrorSweep sweep_;
    std::vector<std::vector<float>> planes_;  // per cycle t < k: planes first_[t], + 2^t, ... <= zb
    std::vector<int64_t> first_;
};

/// Packed errors of planes z1..z2: for t = 0 .. k-1, for the planes z of
/// z1..z2 that are multiples of 2^t (ascending), the lattice plane of cycle t
/// ((box_max.x >> t) + 1) * ((box_max.y >> t) + 1) floats, as error_plane().
std::size_t ht_packed_error_floats(const HtDomain& domain, int64_t z1, int64_t z2);
void ht_unpack_errors(const HtDomain& domain, int64_t z1, int64_t z2, const float* packed, HtErrorPlaneSink& sink);

// ---- Encoding on every process (docs/distributed.md §3.6 step 3) ----

/// The points of a lattice plane of cycle t: ((box_max.x >> t) + 1) * ((box_max.y >> t) + 1).
int64_t ht_lattice_plane_points(const HtDomain& domain, int t);
/// Plane z of B (a multiple of 2^t) on the lattice of spacing 2^t, as the
/// encoder's buffers hold it: ht_lattice_plane_points(t) values of the
/// source's type, written to `out`. Reads source plane min(z, dims.z - 1).
void ht_lattice_values(VolumePlanes& source, bool pad, int t, int64_t z, std::byte* out);

/// A row of bricks: those of cycle t whose brick index along z is `row`.
/// Chunks of one cycle are independent, so rows are what processes share out.
struct HtBrickRow {
    int t = 0;
    int64_t row = 0;
};
/// The rows of every cycle whose first plane (row * 2^(t+1+brick_log2)) lies
/// in za..zb (empty when za > zb), coarse cycles first, rows ascending.
std::vector<HtBrickRow> ht_rows_in(const HtDomain& domain, int brick_log2, int64_t za, int64_t zb);
/// The planes of B a row's coders read: {lo, hi}, both multiples of 2^t; the
/// lattice planes lo, lo + 2^t, ..., hi are what HtRowEncoder::encode takes.
std::array<int64_t, 2> ht_row_window(const HtDomain& domain, int brick_log2, HtBrickRow row);

/// One stored HT chunk section (HT_FIELD or HT_ERRORS of chunk (cycle, brick)).
struct HtSection {
    uint32_t type = 0, flags = 0, cycle = 0, brick = 0;
    uint64_t raw_size = 0, checksum = 0;
    std::vector<std::byte> bytes;
};

/// Encodes rows of bricks into exactly the sections write_ht_container_streaming
/// writes for them, and sums up their errors for METADATA.
class HtRowEncoder {
public:
    HtRowEncoder(const HtDomain& domain, ValueType type, const HtEncodeOptions& options);
    /// `values`: the lattice planes of ht_row_window(row) (ht_lattice_values
    /// each); `errors`: the same planes' errors of cycle t (as
    /// HtErrorPlaneSink::error_plane holds them), null when t == k. Appends the
    /// row's sections, for each brick ascending its field then its errors.
    /// Uses the calling thread and TBB's.
    void encode(HtBrickRow row, const std::byte* values, const float* errors, std::vector<HtSection>& out);
    /// What METADATA summarizes of the errors encoded (merge those of every
    /// process: a maximum and a count, exact in any order).
    struct ErrorStats {
        float raw_max = 0;
        uint64_t always_split = 0;
    };
    ErrorStats error_stats() const { return stats_; }

private:
    HtDomain d_;
    ValueType type_;
    HtEncodeOptions o_;
    ErrorStats stats_;
};

/// Size, flags and checksum of a section encoded somewhere (HtSection without its bytes).
struct HtSectionEntry {
    uint32_t type = 0, flags = 0, cycle = 0, brick = 0;
    uint64_t stored_size = 0, raw_size = 0, checksum = 0;
};
/// Where a container's bytes go when its chunk sections were encoded apart.
struct HtContainerLayout {
    std::vector<std::byte> head;    // written at offset 0: header, table, METADATA, HT_HEADER
    std::vector<uint64_t> offsets;  // of entries[i]
    uint64_t file_size = 0;
};
/// The layout of the container write_ht_container_streaming writes, given the
/// entries of every chunk section (in any order; each exactly once, else
/// InvalidArgument), the metadata it would take (value range set), the
/// merged error stats and the options.
HtContainerLayout ht_distributed_layout(const HtDomain& domain, tlod::Metadata meta, HtRowEncoder::ErrorStats stats,
                                        const HtEncodeOptions& options, const std::vector<HtSectionEntry>& entries);

}  // namespace tetlod
