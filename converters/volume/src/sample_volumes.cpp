#include "tetlod/converters/sample_volumes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <type_traits>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

using Field = double (*)(double x, double y, double z);

double marschner_lobb(double x, double y, double z) {
    constexpr double fM = 6.0;
    constexpr double alpha = 0.25;
    constexpr double pi = std::numbers::pi;
    const double rho = std::cos(2.0 * pi * fM * std::cos(pi * std::sqrt(x * x + y * y) / 2.0));
    return (1.0 - std::sin(pi * z / 2.0) + alpha * (1.0 + rho)) / (2.0 * (1.0 + alpha));
}

double gaussian(double x, double y, double z, double cx, double cy, double cz, double sigma) {
    const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz);
    return std::exp(-d2 / (2.0 * sigma * sigma));
}

double multiscale(double x, double y, double z) {
    constexpr double pi = std::numbers::pi;
    double g = 0.15 * (x + y + z + 3.0) / 6.0;
    g += 0.45 * gaussian(x, y, z, -0.3, -0.2, -0.1, 0.35);
    g += 0.25 * gaussian(x, y, z, 0.45, 0.4, 0.35, 0.12);
    g += 0.15 * gaussian(x, y, z, 0.5, -0.55, 0.5, 0.04);
    g += 0.025 * (1.0 + std::sin(8.0 * pi * x) * std::sin(8.0 * pi * y) * std::sin(8.0 * pi * z));
    return g / 1.05;
}

double sphere(double x, double y, double z) {
    return 1.0 - std::sqrt(x * x + y * y + z * z) / std::numbers::sqrt3;
}

// Archival test cases (issue 13): what general-purpose compressors handle well
// and a predictive coder may not.

// A few small blobs in emptiness: about 99% of the samples are exactly 0, like
// a segmented angiogram or a density far from its molecule.
double sparse(double x, double y, double z) {
    constexpr double c[5][3] = {{-0.5, -0.4, -0.3}, {0.4, 0.5, -0.6}, {0.1, -0.6, 0.55},
                                {-0.6, 0.45, 0.5}, {0.55, -0.1, 0.1}};
    double f = 0;
    for (const auto& p : c) {
        const double d2 = (x - p[0]) * (x - p[0]) + (y - p[1]) * (y - p[1]) + (z - p[2]) * (z - p[2]);
        const double r2 = 0.15 * 0.15;  // 5 balls of radius 0.15: 0.9% of the cube
        if (d2 < r2) f = std::max(f, 1.0 - d2 / r2);
    }
    return f;
}

double constant(double, double, double) { return 0.5; }

// Uniform in [0,1) from the coordinates' bits (splitmix64 finaliser): white
// noise, deterministic and the same on every machine.
double white_noise(double x, double y, double z) {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (double c : {x, y, z}) {
        uint64_t b;
        std::memcpy(&b, &c, sizeof b);
        h ^= b + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
        h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
        h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
        h ^= h >> 31;
    }
    return double(h >> 11) * 0x1.0p-53;
}

// A smooth field under measurement noise: the multiscale field at 80% plus
// 20% white noise (several noisy low bits per sample, as in a scan).
double noisy(double x, double y, double z) { return 0.8 * multiscale(x, y, z) + 0.2 * white_noise(x, y, z); }

struct Sample {
    const char* name;
    Field field;
};

constexpr Sample kSamples[] = {
    {"marschner-lobb", marschner_lobb},
    {"multiscale", multiscale},
    {"sphere", sphere},
    {"sparse", sparse},
    {"constant", constant},
    {"noisy", noisy},
};

// Maps f in [0,1] onto the full range of the integer type T (f is clamped first
// so rounding noise can never wrap around).
template <class T>
T quantise(double f) {
    if constexpr (std::is_floating_point_v<T>) {
        return static_cast<T>(f);
    } else {
        const double lo = static_cast<double>(std::numeric_limits<T>::min());
        const double hi = static_cast<double>(std::numeric_limits<T>::max());
        const double c = f < 0.0 ? 0.0 : (f > 1.0 ? 1.0 : f);
        return static_cast<T>(std::round(lo + c * (hi - lo)));
    }
}

}  // namespace

std::vector<std::string> sample_volume_names() {
    std::vector<std::string> names;
    for (const auto& s : kSamples) names.emplace_back(s.name);
    return names;
}

Volume make_sample_volume(const std::string& name, Dims dims, ValueType type) {
    const Sample* sample = nullptr;
    for (const auto& s : kSamples)
        if (name == s.name) sample = &s;
    if (!sample) {
        std::string known;
        for (const auto& s : kSamples) known += std::string(known.empty() ? "" : ", ") + s.name;
        throw Error(ErrorCode::InvalidArgument,
                    "unknown sample volume '" + name + "' (known: " + known + ")");
    }
    const std::string what = "sample volume '" + name + "'";
    validate_dims(dims, what);
    for (int a = 0; a < 3; ++a)
        if (dims[a] < 2)
            throw Error(ErrorCode::InvalidArgument, what + ": dimension " + std::to_string(a) +
                                                        " is " + std::to_string(dims[a]) +
                                                        " (must be at least 2)");

    Volume v = Volume::allocate(dims, type);
    // Coordinates as -1 + i * step would drift; computing each from its index
    // keeps the end points exactly at -1 and +1.
    auto coord = [](int64_t i, int64_t n) {
        return -1.0 + 2.0 * static_cast<double>(i) / static_cast<double>(n - 1);
    };
    dispatch_value_type(type, [&](auto tag) {
        using T = decltype(tag);
        T* out = v.as<T>();
        for (int64_t k = 0; k < dims.z; ++k) {
            const double z = coord(k, dims.z);
            for (int64_t j = 0; j < dims.y; ++j) {
                const double y = coord(j, dims.y);
                for (int64_t i = 0; i < dims.x; ++i)
                    out[dims.index(i, j, k)] = quantise<T>(sample->field(coord(i, dims.x), y, z));
            }
        }
    });
    for (int a = 0; a < 3; ++a) {
        v.spacing[a] = 2.0 / static_cast<double>(dims[a] - 1);
        v.origin[a] = -1.0;
    }
    v.field_name = name;
    v.metadata["sample"] = name;
    return v;
}

}  // namespace tetlod
