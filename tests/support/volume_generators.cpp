#include "support/volume_generators.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

namespace tetlod::test {
namespace {

uint32_t hash3(uint32_t x, uint32_t y, uint32_t z, uint32_t seed) {
    uint32_t h = seed * 0x9E3779B9u;
    for (uint32_t v : {x, y, z}) {
        h ^= v + 0x7F4A7C15u + (h << 6) + (h >> 2);
        h *= 0x85EBCA6Bu;
        h ^= h >> 13;
        h *= 0xC2B2AE35u;
        h ^= h >> 16;
    }
    return h;
}

// A value in [0, 1].
double unit_value(Field f, int64_t x, int64_t y, int64_t z, uint32_t seed) {
    switch (f) {
        case Field::Smooth: {
            double s = 0.5 + 0.2 * std::sin(0.31 * x + 0.1 * seed) + 0.15 * std::sin(0.23 * y + 0.7 * x * 0.05) +
                       0.15 * std::cos(0.19 * z + 0.05 * y);
            return std::clamp(s, 0.0, 1.0);
        }
        case Field::Noisy: return hash3(uint32_t(x), uint32_t(y), uint32_t(z), seed) / 4294967295.0;
        case Field::Plateau: {
            // terraces of a tilted plane plus a sphere plateau
            double t = std::floor((x + 2 * y + 3 * z) / 7.0) / 8.0;
            double r2 = double(x - 5) * (x - 5) + double(y - 4) * (y - 4) + double(z - 6) * (z - 6);
            if (r2 < 16) t = 0.75;
            return t - std::floor(t);
        }
        case Field::Constant: return 0.5;
    }
    return 0.0;
}

}  // namespace

const char* field_name(Field f) {
    switch (f) {
        case Field::Smooth: return "smooth";
        case Field::Noisy: return "noisy";
        case Field::Plateau: return "plateau";
        case Field::Constant: return "constant";
    }
    return "?";
}

Volume make_volume(Dims dims, ValueType type, Field field, uint32_t seed) {
    Volume v = Volume::allocate(dims, type);
    double lo = 0, hi = 255;
    switch (type) {
        case ValueType::U8: lo = 0, hi = 255; break;
        case ValueType::I8: lo = -100, hi = 100; break;
        case ValueType::U16: lo = 0, hi = 60000; break;
        case ValueType::I16: lo = -3000, hi = 3000; break;
        case ValueType::U32: lo = 0, hi = 1e6; break;
        case ValueType::I32: lo = -1e6, hi = 1e6; break;
        case ValueType::F32:
        case ValueType::F64: lo = -1, hi = 1; break;
    }
    for (int64_t z = 0; z < dims.z; ++z)
        for (int64_t y = 0; y < dims.y; ++y)
            for (int64_t x = 0; x < dims.x; ++x) {
                double u = lo + (hi - lo) * unit_value(field, x, y, z, seed);
                if (!is_float(type)) u = std::round(u);
                if (type == ValueType::F32) u = static_cast<float>(u);
                v.set_value(dims.index(x, y, z), u);
            }
    return v;
}

Volume pad_to_cube(const Volume& v) {
    int64_t m = std::max({v.dims.x, v.dims.y, v.dims.z}) - 1;
    int64_t L = 1;
    while (L < m) L *= 2;
    Dims d{L + 1, L + 1, L + 1};
    Volume out = Volume::allocate(d, v.type);
    out.spacing = v.spacing;
    out.origin = v.origin;
    const std::size_t sz = value_size(v.type);
    for (int64_t z = 0; z <= L; ++z)
        for (int64_t y = 0; y <= L; ++y)
            for (int64_t x = 0; x <= L; ++x) {
                int64_t sx = std::min(x, v.dims.x - 1), sy = std::min(y, v.dims.y - 1), sz2 = std::min(z, v.dims.z - 1);
                std::memcpy(out.data.data() + d.index(x, y, z) * sz, v.data.data() + v.dims.index(sx, sy, sz2) * sz, sz);
            }
    return out;
}

std::optional<Volume> read_raw(const std::string& path, Dims dims, ValueType type) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    Volume v = Volume::allocate(dims, type);
    in.read(reinterpret_cast<char*>(v.data.data()), static_cast<std::streamsize>(v.data.size()));
    if (in.gcount() != static_cast<std::streamsize>(v.data.size())) return std::nullopt;
    char extra;
    if (in.read(&extra, 1)) return std::nullopt;  // longer than declared
    return v;  // host is little-endian (x86-64), as the files
}

}  // namespace tetlod::test
