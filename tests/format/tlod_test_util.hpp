#pragma once
// Deterministic test volumes for the container tests: a smooth field plus noise,
// with the special float values (NaN payloads, -0, infinities, subnormals) mixed in.
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "tetlod/core/volume.hpp"

namespace tlodtest {

inline tetlod::Volume make_volume(tetlod::Dims d, tetlod::ValueType t, unsigned seed,
                                  bool specials = false) {
    using namespace tetlod;
    Volume v = Volume::allocate(d, t);
    std::mt19937 rng(seed);
    dispatch_value_type(t, [&](auto tv) {
        using T = decltype(tv);
        T* p = v.as<T>();
        for (int64_t z = 0; z < d.z; ++z)
            for (int64_t y = 0; y < d.y; ++y)
                for (int64_t x = 0; x < d.x; ++x) {
                    double s = 40 * std::sin(0.3 * x) * std::cos(0.2 * y) + 3 * z + int(rng() % 5);
                    T val;
                    if constexpr (std::is_floating_point_v<T>) {
                        val = T(s * 1.37);
                    } else {
                        val = T(std::llround(s) + (std::is_signed_v<T> ? 0 : 60));
                        if (specials && rng() % 97 == 0) val = std::numeric_limits<T>::max();
                        if (specials && rng() % 89 == 0) val = std::numeric_limits<T>::min();
                    }
                    p[d.index(x, y, z)] = val;
                }
        if constexpr (std::is_floating_point_v<T>) {
            if (specials && d.count() >= 8) {
                p[1] = -T(0);
                p[2] = std::numeric_limits<T>::infinity();
                p[3] = -std::numeric_limits<T>::infinity();
                p[4] = std::numeric_limits<T>::denorm_min();
                p[5] = std::numeric_limits<T>::lowest();
                using U = std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>;
                U nan = sizeof(T) == 4 ? U(0xFFC01234u) : U(0x7FF800000000BEEFull);
                std::memcpy(&p[6], &nan, sizeof(T));
            }
        }
    });
    return v;
}

}  // namespace tlodtest
