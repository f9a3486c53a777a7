#pragma once
// Lattice chunk mode (spec §6.4 mode 4, format 3.3): a field chunk of a lossy
// file (§5.1) whose every value is a multiple of the file's step s (floats
// 2E, integers 2*floor(E)+1, E = field.max_error) is coded as the integer
// indices q of its values, v = q*s. The prediction walk, the contexts and the
// range coder are those of the range mode (§7.4-§7.6); only the residual
// changes: q(v) - q(prediction), where the prediction is mapped to the index
// of the lattice value nearest to it. The lossy writer's lattice candidate is
// such a field, and its float bit patterns are what the range mode codes
// badly (the residual of two adjacent multiples of 2E is an arbitrary
// mantissa difference; here it is 1).
#include <cmath>
#include <optional>
#include <string>

#include "ht_field_chunk_coder.hpp"

namespace tetlod::ht_detail {

/// Spec §6.4: lattice indices satisfy |q| <= 2^52 (every such q is exact in
/// binary64), so residuals of two indices have at most 54 bits.
constexpr int64_t kLatticeMaxIndex = int64_t{1} << 52;
constexpr int kLatticeResidualBits = 54;

/// The file's lattice step from the stated bound E (field.max_error, > 0):
/// floats 2E in binary64, integers 2*floor(min(E, 2^40)) + 1 (what
/// quantize_samples uses). 0 when there is no lattice (E <= 0, or an integer
/// step of 1).
template <class T>
double lattice_step(double stated_e) {
    if (!(stated_e > 0)) return 0;
    if constexpr (std::is_floating_point_v<T>) {
        return 2.0 * stated_e;
    } else {
        const double f = std::floor(std::min(stated_e, 1099511627776.0));
        return f >= 1 ? 2 * f + 1 : 0;
    }
}

/// Values <-> lattice indices for a step s > 0 (spec §6.4, mode 4).
template <class T>
struct LatticeMap {
    using D = Dom<T>;
    double s = 0;
    int64_t si = 0;  // integers: the step as an integer (odd, <= 2^41 + 1)

    explicit LatticeMap(double step) : s(step), si(std::is_floating_point_v<T> ? 0 : int64_t(step)) {}

    static int64_t saturate(int64_t q) { return std::clamp(q, -kLatticeMaxIndex, kLatticeMaxIndex); }

    /// Index of the lattice value nearest to x: floats round(x / s) (binary64
    /// division, ties to even; NaN gives 0), integers floor((x + (s-1)/2) / s);
    /// saturated to +-2^52.
    int64_t index_of_float(double x) const {
        const double d = std::nearbyint(x / s);
        if (!(d == d)) return 0;
        if (d >= double(kLatticeMaxIndex)) return kLatticeMaxIndex;
        if (d <= -double(kLatticeMaxIndex)) return -kLatticeMaxIndex;
        return int64_t(d);
    }
    int64_t index_of_integer(int64_t x) const {  // |x| < 2^62: no overflow
        const int64_t a = x + (si - 1) / 2;
        int64_t q = a / si;
        if (a % si != 0 && a < 0) --q;
        return saturate(q);
    }
    int64_t index(T v) const {
        if constexpr (std::is_floating_point_v<T>) return index_of_float(double(v));
        else return index_of_integer(int64_t(v));
    }
    /// Index of a value given in the predictor's domain (§7.1): floats the
    /// ordered bit pattern, taken mod 2^W; integers the value itself.
    int64_t index_of_domain(int64_t p) const {
        if constexpr (std::is_floating_point_v<T>) return index_of_float(double(D::put(typename D::U(uint64_t(p)))));
        else return index_of_integer(std::clamp<int64_t>(p, -(int64_t{1} << 61), int64_t{1} << 61));
    }
    /// The value of index q: floats the binary64 product q*s rounded to T (0
    /// for q = 0), integers q*s, false when outside the type.
    bool value(int64_t q, T& out) const {
        if constexpr (std::is_floating_point_v<T>) {
            out = q == 0 ? T(0) : T(double(q) * s);
            return true;
        } else {
            const i128 c = i128(q) * si;
            if (c < i128(std::numeric_limits<T>::min()) || c > i128(std::numeric_limits<T>::max())) return false;
            out = T(int64_t(c));
            return true;
        }
    }
    /// Spec §6.4: the index prediction and its activity from a field prediction.
    struct Predicted {
        int64_t q;
        uint64_t spread;
    };
    Predicted predict(const Prediction& pr) const {
        const int64_t q = index_of_domain(pr.p);
        if (pr.spread == 0) return {q, 0};
        const int64_t q2 = index_of_domain(int64_t(uint64_t(pr.p) + pr.spread));
        return {q, q2 >= q ? uint64_t(q2 - q) : uint64_t(q - q2)};
    }
};

/// Whether every value of the chunk is exactly the value of its own index.
template <class T>
bool chunk_on_lattice(const Geometry& G, const T* v, const HtChunk& c, const LatticeMap<T>& L) {
    using U = typename Dom<T>::U;
    bool on = true;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        if (!on) return;
        const T a = v[G.index(x, y, z)];
        T b;
        on = L.value(L.index(a), b) && std::bit_cast<U>(a) == std::bit_cast<U>(b);
    });
    return on;
}

/// The lattice-mode stream of a chunk, or nothing when a value of the chunk
/// is not a lattice value. `step` > 0.
template <class T>
std::optional<std::vector<std::byte>> encode_lattice_chunk(const Geometry& G, const T* v, const HtChunk& c,
                                                           double step) {
    const LatticeMap<T> L(step);
    if (c.points == 0 || !chunk_on_lattice(G, v, c, L)) return std::nullopt;
    std::vector<std::byte> out;
    auto models = std::make_unique<FieldModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    rc::Encoder enc(out);
    auto code = [&](int cls, const Prediction& pr, int64_t idx, int64_t s) {
        const auto p = L.predict(pr);
        const uint64_t act = p.spread + 2 * lat.neighbour_mean(s);
        const int64_t r = L.index(v[idx]) - p.q;  // both within +-2^52
        const bool neg = r < 0;
        const uint64_t mag = neg ? uint64_t(-r) : uint64_t(r);
        rc::encode_int(enc, models->m[cls][activity_bucket(act)], mag, neg, kLatticeResidualBits);
        lat.set(s, mag);
    };
    walk_field_chunk(G, v, c, lat, code);
    enc.finish();
    return out;
}

/// The lattice decoder's step for one point (a value type, as FieldPointDecoder).
template <class T>
struct LatticePointDecoder {
    rc::Decoder dec;
    FieldModels* models = nullptr;
    T* v = nullptr;
    LatticeView lat;
    LatticeMap<T> L;
    bool outside = false;  // an index beyond +-2^52 or a value beyond the type
    RowEvenStrides even;   // of the current row (classes 0..2), as FieldPointDecoder

    uint32_t wprev = 0;    // the lattice at the slot of x − 2h, as FieldPointDecoder

    void begin_row(const ChunkRow& r, int64_t s0) {
        if (r.cls < 3) {
            even = row_even_strides(r, lat);
            wprev = lat.mag[s0 - 2];
        }
    }

    void operator()(int cls, const Prediction& pr, int64_t idx, int64_t s) {
        if (dec.overrun() || outside) return;  // a valid stream never gets here: skip the rest
        const auto p = L.predict(pr);
        const uint64_t mean =
            cls < 3 ? lat.neighbour_mean_in_order_prev(cls, s, even.even1, even.even2, wprev) : lat.neighbour_mean(s);
        const uint64_t act = p.spread + 2 * mean;
        uint64_t mag;
        bool neg;
        rc::decode_int(dec, models->m[cls][activity_bucket(act)], mag, neg, kLatticeResidualBits);
        // mag < 2^54 and |p.q| <= 2^52: no overflow.
        const int64_t q = p.q + (neg ? -int64_t(mag) : int64_t(mag));
        T value{};
        if (q < -kLatticeMaxIndex || q > kLatticeMaxIndex || !L.value(q, value)) {
            outside = true;
            return;
        }
        v[idx] = value;
        lat.set(s, mag);
        wprev = LatticeView::stored(mag);
    }
};

/// Decodes a lattice-mode chunk with step `step` (0: the file has none).
/// Returns an empty string or what is wrong.
template <class T>
std::string decode_lattice_chunk(const Geometry& G, T* v, const HtChunk& c, double step,
                                 std::span<const std::byte> in) {
    if (!(step > 0)) return "lattice chunk in a file without a lattice step (not lossy, or integer E < 1)";
    if (c.points == 0) return "empty lattice chunk";
    auto models = std::make_unique<FieldModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    LatticePointDecoder<T> step_dec{rc::Decoder(in.data(), in.size()), models.get(), v, lat.view(),
                                    LatticeMap<T>(step), false, {}, 0};
    walk_field_chunk(G, v, c, lat, step_dec);
    if (step_dec.outside) return "lattice index outside +-2^52 or value outside the type";
    if (step_dec.dec.bad_end()) return "malformed lattice-coded stream";
    return "";
}

}  // namespace tetlod::ht_detail
