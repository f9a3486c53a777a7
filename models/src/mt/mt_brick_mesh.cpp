// Packed hand-over mesh of the MT build (record layout: mt_brick_mesh.hpp).
#include "mt_brick_mesh.hpp"

#include <algorithm>
#include <cstring>

namespace tetlod::mt {

namespace {

constexpr uint8_t kErrStored = 1u << 4;

uint32_t bits_of(float f) {
    uint32_t b;
    std::memcpy(&b, &f, sizeof b);
    return b;
}
float float_of(uint32_t b) {
    float f;
    std::memcpy(&f, &b, sizeof f);
    return f;
}
// Vertices and points of a tet lie within a few cells of each other, so their offsets
// from the first vertex are short in either direction.
uint32_t zigzag(uint32_t x, uint32_t base) {
    const int64_t d = int64_t(x) - int64_t(base);  // grid indices are < 2^31
    return d < 0 ? uint32_t(-d) * 2 - 1 : uint32_t(d) * 2;
}
uint32_t unzigzag(uint32_t z, uint32_t base) {
    const int64_t d = (z & 1) ? -(int64_t(z >> 1) + 1) : int64_t(z >> 1);
    return uint32_t(int64_t(base) + d);
}
size_t varint_size(uint32_t x) {
    size_t n = 1;
    while (x >= 0x80) x >>= 7, ++n;
    return n;
}
void put_varint(std::vector<uint8_t>& out, uint32_t x) {
    while (x >= 0x80) out.push_back(uint8_t(x | 0x80)), x >>= 7;
    out.push_back(uint8_t(x));
}
void put_float(std::vector<uint8_t>& out, float f) {
    const uint32_t b = bits_of(f);
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(b >> (8 * i)));
}
float largest_face_error(const std::array<float, 4>& f) {
    return std::max(std::max(f[0], f[1]), std::max(f[2], f[3]));
}
uint8_t flags_of(const HandedTet& t) {
    uint8_t flags = 0;
    for (int k = 0; k < 4; ++k)
        if (bits_of(t.face_err[k]) != 0) flags |= uint8_t(1u << k);
    if (bits_of(t.err) != bits_of(largest_face_error(t.face_err))) flags |= kErrStored;
    return flags;
}

}  // namespace

size_t BrickMesh::record_size(const HandedTet& t, const uint32_t* points) {
    const uint8_t flags = flags_of(t);
    size_t n = varint_size(t.v[0]) + 1 + varint_size(t.points);
    for (int i = 1; i < 4; ++i) n += varint_size(zigzag(t.v[i], t.v[0]));
    for (int k = 0; k < 5; ++k) n += (flags >> k & 1) ? 4 : 0;
    for (uint32_t i = 0; i < t.points; ++i) n += varint_size(zigzag(points[i], t.v[0]));
    return n;
}

void BrickMesh::append(const HandedTet& t, const uint32_t* pts) {
    const uint8_t flags = flags_of(t);
    put_varint(bytes, t.v[0]);
    for (int i = 1; i < 4; ++i) put_varint(bytes, zigzag(t.v[i], t.v[0]));
    bytes.push_back(flags);
    for (int k = 0; k < 4; ++k)
        if (flags >> k & 1) put_float(bytes, t.face_err[k]);
    if (flags & kErrStored) put_float(bytes, t.err);
    put_varint(bytes, t.points);
    for (uint32_t i = 0; i < t.points; ++i) put_varint(bytes, zigzag(pts[i], t.v[0]));
    ++tets;
    points += t.points;
}

void BrickMesh::append_record(const BrickMesh& from, size_t begin, size_t end, uint32_t pts) {
    bytes.insert(bytes.end(), from.bytes.begin() + ptrdiff_t(begin), from.bytes.begin() + ptrdiff_t(end));
    ++tets;
    points += pts;
}

uint32_t BrickMeshReader::varint() {
    uint32_t x = 0;
    for (int shift = 0;; shift += 7) {
        const uint8_t b = m_.bytes[at_++];
        x |= uint32_t(b & 0x7F) << shift;
        if (!(b & 0x80)) return x;
    }
}

bool BrickMeshReader::next(HandedTet& t) {
    if (left_ != 0) skip_points();
    if (at_ >= m_.bytes.size()) return false;
    begin_ = at_;
    t.v[0] = v0_ = varint();
    for (int i = 1; i < 4; ++i) t.v[i] = unzigzag(varint(), v0_);
    const uint8_t flags = m_.bytes[at_++];
    for (int k = 0; k < 4; ++k) {
        uint32_t b = 0;
        if (flags >> k & 1) {
            for (int i = 0; i < 4; ++i) b |= uint32_t(m_.bytes[at_++]) << (8 * i);
        }
        t.face_err[k] = float_of(b);
    }
    if (flags & kErrStored) {
        uint32_t b = 0;
        for (int i = 0; i < 4; ++i) b |= uint32_t(m_.bytes[at_++]) << (8 * i);
        t.err = float_of(b);
    } else {
        t.err = largest_face_error(t.face_err);
    }
    t.points = left_ = varint();
    return true;
}

uint32_t BrickMeshReader::point() {
    --left_;
    return unzigzag(varint(), v0_);
}

void BrickMeshReader::skip_points() {
    for (; left_ != 0; --left_) varint();
}

}  // namespace tetlod::mt
