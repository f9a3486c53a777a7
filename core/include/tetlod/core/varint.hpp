#pragma once
// LEB128 varints and zigzag signs, as the MT coding, the compact section table
// and the MT builder's packed meshes write them. Readers stay with their
// formats: each has its own rules for a malformed varint (the section table
// refuses a non-shortest form, the MT streams latch a failure).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tetlod {

/// Appends v as a little-endian base-128 varint (7 bits a byte, high bit = more).
template <class Byte>
void put_varint(std::vector<Byte>& out, uint64_t v) {
    while (v >= 0x80) {
        out.push_back(Byte(static_cast<uint8_t>(v | 0x80)));
        v >>= 7;
    }
    out.push_back(Byte(static_cast<uint8_t>(v)));
}

/// Bytes put_varint writes for v.
constexpr std::size_t varint_size(uint64_t v) {
    std::size_t n = 1;
    while (v >= 0x80) v >>= 7, ++n;
    return n;
}

/// Signed to unsigned with small magnitudes small: 0, -1, 1, -2, ... -> 0, 1, 2, 3, ...
constexpr uint64_t zigzag(int64_t v) { return (uint64_t(v) << 1) ^ (0 - (uint64_t(v) >> 63)); }
constexpr int64_t unzigzag(uint64_t v) { return int64_t(v >> 1) ^ -int64_t(v & 1); }

}  // namespace tetlod
