#pragma once
// A dense scalar volume on a regular grid: the input of every model builder and
// the output of every volume decoder. x varies fastest, then y, then z.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "tetlod/core/value_type.hpp"
#include "tetlod/core/zeroed_allocator.hpp"

namespace tetlod {

struct Dims {
    int64_t x = 0, y = 0, z = 0;
    int64_t count() const { return x * y * z; }
    int64_t index(int64_t i, int64_t j, int64_t k) const { return (k * y + j) * x + i; }
    int64_t operator[](int a) const { return a == 0 ? x : (a == 1 ? y : z); }
    bool operator==(const Dims&) const = default;
};

using Vec3 = std::array<double, 3>;

/// Largest grid a volume may declare (points). Headers claiming more are refused
/// before any allocation: 2^34 points is 16 G samples, beyond any machine we target.
inline constexpr int64_t kMaxVolumePoints = int64_t{1} << 34;
/// Largest extent along one axis.
inline constexpr int64_t kMaxAxisSize = int64_t{1} << 20;

struct Volume {
    Dims dims;
    ValueType type = ValueType::U8;
    /// Values in host (little-endian) byte order, dims.count() * value_size(type) bytes.
    /// Fresh storage is zero and committed only where written (zeroed_allocator.hpp).
    ZeroedVector<std::byte> data;
    Vec3 spacing{1.0, 1.0, 1.0};
    Vec3 origin{0.0, 0.0, 0.0};
    std::string field_name = "value";
    std::string units;
    /// Free-form key/values carried through every conversion (provenance, user keys,
    /// keys from source formats). Keys are case-sensitive UTF-8.
    std::map<std::string, std::string> metadata;

    /// Allocates zeroed storage for dims x type (throws tetlod::Error if the dims are
    /// invalid or too large). Pages are committed as they are written, so a decoder
    /// that fails early has cost only what it wrote.
    static Volume allocate(Dims dims, ValueType type);

    int64_t count() const { return dims.count(); }
    std::size_t bytes() const { return data.size(); }

    template <class T> const T* as() const { return reinterpret_cast<const T*>(data.data()); }
    template <class T> T* as() { return reinterpret_cast<T*>(data.data()); }

    /// Value at linear index i, converted to double (exact for every ValueType).
    double value(int64_t i) const;
    double value(int64_t x, int64_t y, int64_t z) const { return value(dims.index(x, y, z)); }
    void set_value(int64_t i, double v);

    /// Minimum and maximum over all samples (NaNs ignored; {0,0} when all NaN).
    std::array<double, 2> range() const;
};

/// The samples of `v` with index below `dims` on every axis (dims <= v.dims),
/// with its spacing, origin, names and metadata: a padded grid cut back to
/// the data it was padded from.
Volume crop_volume(const Volume& v, const Dims& dims);

/// Checks dims are each in [1, kMaxAxisSize] and the total below kMaxVolumePoints.
/// Throws tetlod::Error(InvalidArgument or TooLarge) naming `what`.
void validate_dims(const Dims& dims, const std::string& what);

}  // namespace tetlod
