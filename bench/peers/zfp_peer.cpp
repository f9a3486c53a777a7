// zfp (Lindstrom, "Fixed-Rate Compressed Floating-Point Arrays", IEEE TVCG
// 2014) through libzfp's C API. zfp codes int32, int64, float and double only:
// integer volumes are widened to int32 for the reversible mode and to float for
// fixed accuracy (zfp ignores the accuracy on integer arrays and would code
// them losslessly); both conversions are exact for 8- and 16-bit samples, and
// count in the timed calls, since a user of zfp would pay them too.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

#include "peer.hpp"

#if TETLOD_BENCH_HAVE_ZFP
#include <zfp.h>
#endif

namespace tetlod::bench {

#if TETLOD_BENCH_HAVE_ZFP
namespace {

// The samples widened to what zfp codes: `widen_to_int` picks int32 for
// integer volumes, else float; f32 and f64 volumes stay as they are.
struct Widened {
    zfp_type type = zfp_type_none;
    std::vector<std::byte> bytes;
};

Widened widen(const Volume& v, bool widen_to_int) {
    Widened w;
    if (v.type == ValueType::F32 || v.type == ValueType::F64) {
        w.type = v.type == ValueType::F32 ? zfp_type_float : zfp_type_double;
        w.bytes.assign(v.data.begin(), v.data.end());
        return w;
    }
    const std::size_t n = v.count();
    w.type = widen_to_int ? zfp_type_int32 : zfp_type_float;
    w.bytes.resize(n * 4);
    dispatch_value_type(v.type, [&](auto tag) {
        using T = decltype(tag);
        const T* in = v.as<T>();
        if (widen_to_int) {
            auto* out = reinterpret_cast<int32_t*>(w.bytes.data());
            for (std::size_t i = 0; i < n; ++i) out[i] = int32_t(in[i]);
        } else {
            auto* out = reinterpret_cast<float*>(w.bytes.data());
            for (std::size_t i = 0; i < n; ++i) out[i] = float(in[i]);
        }
    });
    return w;
}

// Back to the volume's type (rounding, clamped to the type: a lossy decode
// may step outside it) and the largest deviation from the original.
Volume narrow(const Volume& original, const Widened& w, double& max_error) {
    Volume out = Volume::allocate(original.dims, original.type);
    const std::size_t n = original.count();
    max_error = 0;
    dispatch_value_type(original.type, [&](auto tag) {
        using T = decltype(tag);
        T* o = out.as<T>();
        const T* in = original.as<T>();
        for (std::size_t i = 0; i < n; ++i) {
            double d;
            if (w.type == zfp_type_int32) d = reinterpret_cast<const int32_t*>(w.bytes.data())[i];
            else if (w.type == zfp_type_float) d = reinterpret_cast<const float*>(w.bytes.data())[i];
            else d = reinterpret_cast<const double*>(w.bytes.data())[i];
            if constexpr (std::is_integral_v<T>)
                o[i] = T(std::clamp(std::round(d), double(std::numeric_limits<T>::lowest()),
                                    double(std::numeric_limits<T>::max())));
            else
                o[i] = T(d);
            max_error = std::max(max_error, std::abs(double(o[i]) - double(in[i])));
        }
    });
    return out;
}

PeerResult run(const Volume& v, bool reversible, double tolerance, double min_seconds) {
    PeerResult r;
    r.available = true;
    const std::size_t raw = v.data.size();
    std::vector<std::byte> buffer;
    std::size_t stored = 0;
    // zfp's x is the fastest axis, as in a Volume.
    const auto compress = [&] {
        Widened w = widen(v, reversible);
        zfp_field* f = zfp_field_3d(w.bytes.data(), w.type, std::size_t(v.dims.x), std::size_t(v.dims.y),
                                    std::size_t(v.dims.z));
        zfp_stream* z = zfp_stream_open(nullptr);
        if (reversible) zfp_stream_set_reversible(z);
        else zfp_stream_set_accuracy(z, tolerance);
        buffer.resize(zfp_stream_maximum_size(z, f) + 64);
        bitstream* s = stream_open(buffer.data(), buffer.size());
        zfp_stream_set_bit_stream(z, s);
        zfp_stream_rewind(z);
        zfp_write_header(z, f, ZFP_HEADER_FULL);
        stored = zfp_compress(z, f);
        zfp_field_free(f);
        zfp_stream_close(z);
        stream_close(s);
    };
    const double enc = seconds_per_call(compress, min_seconds);
    if (stored == 0) {
        r.available = false;
        r.why = "zfp_compress failed";
        return r;
    }
    Volume back;
    const auto decompress = [&] {
        zfp_stream* z = zfp_stream_open(nullptr);
        bitstream* s = stream_open(buffer.data(), stored);
        zfp_stream_set_bit_stream(z, s);
        zfp_stream_rewind(z);
        zfp_field* f = zfp_field_alloc();
        Widened w;
        bool ok = zfp_read_header(z, f, ZFP_HEADER_FULL) != 0;
        if (ok) {
            w.type = zfp_field_type(f);
            w.bytes.resize(v.count() * zfp_type_size(w.type));
            zfp_field_set_pointer(f, w.bytes.data());
            ok = zfp_decompress(z, f) != 0;
        }
        zfp_field_free(f);
        zfp_stream_close(z);
        stream_close(s);
        back = ok ? narrow(v, w, r.max_error) : Volume{};
    };
    const double dec = seconds_per_call(decompress, min_seconds);
    r.bytes = stored;
    r.exact = back.data == v.data;
    r.encode_mbs = double(raw) / enc / 1e6;
    r.decode_mbs = double(raw) / dec / 1e6;
    return r;
}

}  // namespace

PeerResult run_zfp_reversible(const Volume& v, double min_seconds) { return run(v, true, 0, min_seconds); }
PeerResult run_zfp_accuracy(const Volume& v, double tolerance, double min_seconds) {
    return run(v, false, tolerance, min_seconds);
}
#else
PeerResult run_zfp_reversible(const Volume&, double) { return {false, "built without libzfp"}; }
PeerResult run_zfp_accuracy(const Volume&, double, double) { return {false, "built without libzfp"}; }
#endif

}  // namespace tetlod::bench
