#pragma once
// Residual coding 1 (format 1.x): zigzag byte planes + zstd, per chunk.

#include <span>

#include "ht_chunk_geometry.hpp"

namespace tetlod::ht_detail {


template <class T>
std::vector<std::byte> encode_field_chunk(const Geometry& G, const T* v, const HtChunk& c) {
    using D = Dom<T>;
    constexpr int B = int(sizeof(T));
    const std::size_t n = c.points;
    std::vector<std::byte> raw(n * B);
    std::size_t i = 0;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        const int64_t p = G.predict(v, c.cycle, x, y, z);
        const typename D::U r = typename D::U(uint64_t(D::get(v[G.index(x, y, z)])) - uint64_t(p));
        const typename D::U zz = D::zigzag(r);
        for (int b = 0; b < B; ++b) raw[b * n + i] = std::byte(uint8_t(uint64_t(zz) >> (8 * b)));
        ++i;
    });
    return raw;
}

template <class T>
void decode_field_chunk(const Geometry& G, T* v, const HtChunk& c, const std::byte* raw) {
    using D = Dom<T>;
    constexpr int B = int(sizeof(T));
    const std::size_t n = c.points;
    std::size_t i = 0;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        uint64_t zz = 0;
        for (int b = 0; b < B; ++b) zz |= uint64_t(std::to_integer<uint8_t>(raw[b * n + i])) << (8 * b);
        const typename D::U r = D::unzigzag(typename D::U(zz));
        const int64_t p = G.predict(v, c.cycle, x, y, z);
        v[G.index(x, y, z)] = D::put(typename D::U(uint64_t(p) + uint64_t(r)));
        ++i;
    });
}

template <class T>
std::vector<std::byte> encode_error_chunk(const Geometry& G, const T* v, std::span<const float> e,
                                          const HtChunk& c, int m) {
    const std::size_t n = c.diamonds;
    std::vector<std::byte> raw(n * 2);
    if (n == 0) return raw;
    std::size_t i = 0;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        const uint16_t q = uint16_t(quantize_error(e[G.index(x, y, z)], m) -
                                    G.spine_code(v, c.cycle, x, y, z, m));
        raw[i] = std::byte(uint8_t(q));
        raw[n + i] = std::byte(uint8_t(q >> 8));
        ++i;
    });
    return raw;
}

/// False when a code is out of range.
template <class T>
bool decode_error_chunk(const Geometry& G, const T* v, float* e, const HtChunk& c, int m,
                        const std::byte* raw) {
    const std::size_t n = c.diamonds;
    if (n == 0) return true;
    std::size_t i = 0;
    bool ok = true;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        const uint32_t d = std::to_integer<uint8_t>(raw[i]) | (uint32_t(std::to_integer<uint8_t>(raw[n + i])) << 8);
        const uint32_t q = (d + G.spine_code(v, c.cycle, x, y, z, m)) & 0xFFFFu;
        if (q > max_error_code(m)) ok = false;
        e[G.index(x, y, z)] = ok ? dequantize_error(uint16_t(q), m) : std::numeric_limits<float>::infinity();
        ++i;
    });
    return ok;
}

}  // namespace tetlod::ht_detail
