// Error-bounded quantization of a field (see lossy_field.hpp).
#include "tetlod/codecs/lossy_field.hpp"

#include <tbb/parallel_for.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

namespace tetlod {

namespace {

/// Integers: the nearest multiple of the odd step s = 2*floor(E)+1 is within
/// floor(E) <= E; clamping to the type only moves it towards the sample.
template <class T>
T quantize_integer(T v, int64_t s) {
    const int64_t half = (s - 1) / 2;
    const int64_t x = int64_t(v) + half;
    int64_t q = x / s;
    if (x % s != 0 && x < 0) --q;  // floor division
    const int64_t c = q * s;       // |c| <= |v| + s: no overflow for s <= 2^41
    const int64_t lo = int64_t(std::numeric_limits<T>::min()), hi = int64_t(std::numeric_limits<T>::max());
    return T(c < lo ? lo : c > hi ? hi : c);
}

/// Floats: the nearest multiple of 2E in double, rounded to T, kept only when
/// the rounded distance is below E (the true distance then is at most E:
/// rounding is monotone and E is a double); otherwise the sample itself.
template <class T>
T quantize_float(T v, double step, double e) {
    const double q = std::nearbyint(double(v) / step);
    const double c = q == 0 ? 0.0 : q * step;  // 0: also when step is +inf
    const T t = T(c);
    if (t == v) return v;
    if (std::fabs(double(t) - double(v)) < e) return t == 0 ? T(0) : t;  // no -0
    return v;
}

template <class T>
void quantize_range(T* p, std::size_t n, double e) {
    if constexpr (std::is_floating_point_v<T>) {
        const double step = 2.0 * e;
        for (std::size_t i = 0; i < n; ++i) p[i] = quantize_float(p[i], step, e);
    } else {
        // Integer types span less than 2^33: a step above 2^41 maps all to 0.
        const double f = std::floor(std::min(e, 1099511627776.0));
        const int64_t s = 2 * int64_t(f) + 1;
        if (s == 1) return;  // E < 1: integers are already exact
        for (std::size_t i = 0; i < n; ++i) p[i] = quantize_integer(p[i], s);
    }
}

void check(double e) {
    if (!(e > 0) || !std::isfinite(e))
        throw Error(ErrorCode::InvalidArgument, "lossy max error must be finite and > 0");
}

}  // namespace

void quantize_samples(ValueType type, std::byte* data, std::size_t count, double e) {
    check(e);
    dispatch_value_type(type, [&](auto tag) {
        using T = decltype(tag);
        T* p = reinterpret_cast<T*>(data);
        constexpr std::size_t kGrain = std::size_t{1} << 16;
        tbb::parallel_for(std::size_t(0), (count + kGrain - 1) / kGrain, [&](std::size_t b) {
            const std::size_t lo = b * kGrain;
            quantize_range(p + lo, std::min(kGrain, count - lo), e);
        });
    });
}

void quantize_volume(Volume& v, double e) { quantize_samples(v.type, v.data.data(), std::size_t(v.count()), e); }

double stored_max_error(ValueType type, double e) {
    if (!(e > 0)) return 0;
    return is_float(type) ? e : std::floor(e);
}

std::array<double, 2> planes_value_range(VolumePlanes& planes) {
    const Volume& h = planes.header();
    const std::size_t plane = std::size_t(h.dims.x * h.dims.y);
    std::vector<std::byte> buf(plane * value_size(h.type));
    bool any = false;
    double lo = 0, hi = 0;
    for (int64_t z = 0; z < h.dims.z; ++z) {
        planes.read(z, 1, buf.data());
        dispatch_value_type(h.type, [&](auto tag) {
            using T = decltype(tag);
            const T* p = reinterpret_cast<const T*>(buf.data());
            for (std::size_t i = 0; i < plane; ++i) {
                const double v = double(p[i]);
                if (std::isnan(v)) continue;
                if (!any) lo = hi = v, any = true;
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
        });
    }
    return {lo, hi};
}

float bound_against_original(float stored, double e) {
    if (!std::isfinite(stored)) return stored;
    // One double ulp up covers the rounding of the sum, then round up to float.
    const double s = std::nextafter(double(stored) + e, std::numeric_limits<double>::infinity());
    float f = float(s);
    if (double(f) < s) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

std::string format_max_error(double e) {
    char b[64];
    const auto r = std::to_chars(b, b + sizeof b, e);  // shortest round-trip form
    return std::string(b, r.ptr);
}

Expected<double> parse_max_error(const std::string& text) {
    double v = 0;
    const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
    if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size())
        return fail(ErrorCode::CorruptData, "lossy container: field.max_error '" + text + "' is not a number");
    if (!std::isfinite(v) || !(v > 0))
        return fail(ErrorCode::CorruptData,
                    "lossy container: field.max_error '" + text + "' must be finite and > 0");
    return v;
}

}  // namespace tetlod
