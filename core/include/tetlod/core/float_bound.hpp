#pragma once
// Bounds are stated as float32 (per-tet errors, stored codes): a bound computed
// in double must be rounded up, never to nearest, to stay a bound.
#include <cmath>
#include <limits>

namespace tetlod {

/// The smallest float >= v (v >= 0; +inf when v is beyond the float range).
inline float float_at_least(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

}  // namespace tetlod
