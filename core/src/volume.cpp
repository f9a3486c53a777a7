#include "tetlod/core/volume.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include "tetlod/core/error.hpp"

namespace tetlod {

void validate_dims(const Dims& d, const std::string& what) {
    for (int a = 0; a < 3; ++a) {
        if (d[a] < 1)
            throw Error(ErrorCode::InvalidArgument,
                        what + ": dimension " + std::to_string(a) + " is " + std::to_string(d[a]) +
                            " (must be at least 1)");
        if (d[a] > kMaxAxisSize)
            throw Error(ErrorCode::TooLarge, what + ": dimension " + std::to_string(d[a]) +
                                                 " exceeds the limit of " +
                                                 std::to_string(kMaxAxisSize));
    }
    if (d.count() > kMaxVolumePoints)
        throw Error(ErrorCode::TooLarge, what + ": " + std::to_string(d.count()) +
                                             " grid points exceed the limit of " +
                                             std::to_string(kMaxVolumePoints));
}

Volume Volume::allocate(Dims dims, ValueType type) {
    validate_dims(dims, "volume");
    Volume v;
    v.dims = dims;
    v.type = type;
    v.data.resize(static_cast<std::size_t>(dims.count()) * value_size(type));  // zero, untouched
    return v;
}

double Volume::value(int64_t i) const {
    return dispatch_value_type(type, [&](auto t) {
        using T = decltype(t);
        T v;
        std::memcpy(&v, data.data() + static_cast<std::size_t>(i) * sizeof(T), sizeof(T));
        return static_cast<double>(v);
    });
}

void Volume::set_value(int64_t i, double value) {
    dispatch_value_type(type, [&](auto t) {
        using T = decltype(t);
        T v = static_cast<T>(value);
        std::memcpy(data.data() + static_cast<std::size_t>(i) * sizeof(T), &v, sizeof(T));
    });
}

Volume crop_volume(const Volume& v, const Dims& dims) {
    if (dims.x > v.dims.x || dims.y > v.dims.y || dims.z > v.dims.z)
        throw Error(ErrorCode::InvalidArgument, "crop_volume: the crop is larger than the volume");
    Volume out = Volume::allocate(dims, v.type);
    const std::size_t w = value_size(v.type);
    for (int64_t z = 0; z < dims.z; ++z)
        for (int64_t y = 0; y < dims.y; ++y)
            std::memcpy(out.data.data() + std::size_t(dims.index(0, y, z)) * w,
                        v.data.data() + std::size_t(v.dims.index(0, y, z)) * w, std::size_t(dims.x) * w);
    out.spacing = v.spacing;
    out.origin = v.origin;
    out.field_name = v.field_name;
    out.units = v.units;
    out.metadata = v.metadata;
    return out;
}

std::array<double, 2> Volume::range() const {
    return dispatch_value_type(type, [&](auto t) {
        using T = decltype(t);
        const T* p = as<T>();
        const int64_t n = count();
        if constexpr (std::is_integral_v<T>) {
            // In the type itself, so that the loop vectorizes (a conversion to
            // double per sample did not): several passes of a conversion call it.
            if (n == 0) return std::array<double, 2>{0.0, 0.0};
            T tlo = p[0], thi = p[0];
            for (int64_t i = 1; i < n; ++i) tlo = std::min(tlo, p[i]), thi = std::max(thi, p[i]);
            return std::array<double, 2>{static_cast<double>(tlo), static_cast<double>(thi)};
        }
        double lo = std::numeric_limits<double>::infinity();
        double hi = -lo;
        for (int64_t i = 0; i < n; ++i) {
            double v = static_cast<double>(p[i]);
            if (v < lo) lo = v;
            if (v > hi) hi = v;
        }
        if (!(lo <= hi)) return std::array<double, 2>{0.0, 0.0};
        return std::array<double, 2>{lo, hi};
    });
}

}  // namespace tetlod
