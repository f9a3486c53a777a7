#pragma once
// Residual coding 2, field chunks (spec §7.3-§7.5): residuals of the prediction
// through the adaptive range coder.

#include "ht_chunk_rows.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace tetlod::ht_detail {

/// The field's contexts (spec §7.6): per class, one bucket of spread + 2 nbr
/// (16 models), or, in range-2d chunks (mode 5, format 3.6), the spread's and
/// the neighbour mean's buckets apart, 8 x 8 (64 models; class 3, whose spread
/// is 0, keeps the 16 of one bucket). The sum mixes a point with a steep but
/// exactly predicted slope and one in a busy neighbourhood; apart, bucky 128^3's
/// field is 18 % smaller (docs/archival.md, "Static tables, and two-dimensional
/// contexts").
template <bool TwoD>
struct FieldModelsOf {
    rc::IntModel m[4][TwoD ? 64 : 16];
};
using FieldModels = FieldModelsOf<false>;

/// The cap of each dimension of a 2d context: buckets 0..7. Caps of 5, 9 and
/// 11 were measured too: 7 is within 0.5 % of the best on every volume but
/// headsq (1.6 % behind a cap of 9).
constexpr int kContext2dCap = 7;

/// A point's model index within its class (spec §7.6): `spread` of its
/// prediction, `mean` its neighbours' mean magnitude nbr(c).
template <bool TwoD>
[[gnu::always_inline]] inline int field_context(int cls, uint64_t spread, uint64_t mean) {
    if constexpr (TwoD) {
        if (cls < 3)
            return (kContext2dCap + 1) * std::min(kContext2dCap, activity_bucket(spread)) +
                   std::min(kContext2dCap, activity_bucket(2 * mean));
    }
    return activity_bucket(spread + 2 * mean);
}

/// Walks a chunk's points in coding order 2 and calls
/// f(cls, prediction, field index, lattice slot) for each: the encoder and the
/// decoder share it, so they cannot disagree on order or prediction. A
/// copy-assignable f (a value type, not a lambda) is copied into a local for
/// each row and back after it, so its state can live in registers (its
/// operator() and everything it calls must then be inlined: a call taking
/// the local's address would put it back in memory).
template <class T, class F>
void walk_field_chunk(const Geometry& G, const T* v, const HtChunk& c, const ChunkLattice& lat, F& f) {
    const ChunkFrame Fr(G, c.cycle, c.box);
    const int t = c.cycle;
    for_each_row_v2(G, t, c.box, [&](const ChunkRow& row) {
        dispatch_row_class(row, [&]<int Cls>(const ChunkRow& r) {
            int64_t idx = G.index(r.x0, r.y, r.z);
            int64_t s = lat.slot(r.x0, r.y, r.z);
            const int64_t didx = G.index_delta(r.step, 0, 0), ds = r.step >> t;
            if constexpr (Cls == 3) {
                for (int64_t x = r.x0; x <= r.x1; x += r.step, idx += didx, s += ds) f(Cls, Prediction{}, idx, s);
            } else {
                const RowPredictor<T, Cls> P(G, Fr, r);
                // The loop is forced inline where the local copy is made: GCC
                // kept it an out-of-line lambda, the copy's address escaped
                // into it and the coder's state lived in memory, reloaded
                // after every store of a decoded value.
                auto row = [&](F& step_ref) {
                    // A step may want what is fixed along the row (the decoder: its
                    // even axes, the lattice at the slot before the row's first point),
                    // told before its copy is made.
                    if constexpr (requires { step_ref.begin_row(r, s); }) step_ref.begin_row(r, s);
                    else if constexpr (requires { step_ref.begin_row(r); }) step_ref.begin_row(r);
                    auto run = [&](auto& step) __attribute__((always_inline)) {
                        // Everything the loop reads in locals: a decoded u8 value's
                        // store may alias anything reached through a reference (the
                        // row, the indices captured by reference), which the loop then
                        // reloaded (and, for the indices, stored) at every point.
                        const RowPredictor<T, Cls> Pl = P;
                        const int64_t x1 = r.x1, xs = r.step, y = r.y, z = r.z;
                        int64_t li = idx, ls = s;
                        for (int64_t x = r.x0; x <= x1; x += xs, li += didx, ls += ds) {
                            const Prediction pr =
                                Pl.fixed(x) ? Pl.at(v, li, x) : predict_v2(G, v, t, Cls, x, y, z, Fr.cb);
                            step(Cls, pr, li, ls);
                        }
                    };
                    if constexpr (std::is_copy_assignable_v<F>) {
                        F local = step_ref;
                        run(local);
                        step_ref = local;
                    } else {
                        run(step_ref);
                    }
                };
                row(f);
            }
        });
    });
}

/// The encoder's step for one point, a value type for the same reason as
/// FieldPointDecoder below: its coder state and lattice pointer then stay in
/// locals across a row.
template <class T, bool TwoD = false>
struct FieldPointEncoder {
    rc::Encoder enc;
    FieldModelsOf<TwoD>* models = nullptr;
    const T* v = nullptr;
    LatticeView lat;

    [[gnu::always_inline]] void operator()(int cls, const Prediction& pr, int64_t idx, int64_t s) {
        using D = Dom<T>;
        const int ctx = field_context<TwoD>(cls, pr.spread, lat.neighbour_mean(s));
        const auto r = typename D::S(typename D::U(uint64_t(D::get(v[idx])) - uint64_t(pr.p)));
        const bool neg = r < 0;
        const uint64_t mag = neg ? uint64_t(0) - uint64_t(int64_t(r)) : uint64_t(r);
        rc::encode_int(enc, models->m[cls][ctx], mag, neg, D::W);
        lat.set(s, mag);
    }
};

/// The range-coded stream of a field chunk: mode 0's contexts, or with TwoD
/// those of mode 5 (range-2d).
template <class T, bool TwoD = false>
std::vector<std::byte> encode_field_chunk_v2(const Geometry& G, const T* v, const HtChunk& c) {
    std::vector<std::byte> out;
    if (c.points == 0) return out;
    auto models = std::make_unique<FieldModelsOf<TwoD>>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    prefetch_chunk(G, v, c.cycle, c.box, 1);
    FieldPointEncoder<T, TwoD> step{rc::Encoder(out), models.get(), v, lat.view()};
    walk_field_chunk(G, v, c, lat, step);
    step.enc.finish();
    return out;
}

/// Both range streams of a field chunk, mode 0's and mode 5's, from one walk
/// (the prediction and the lattice are the same; only the context differs):
/// the encoder keeps the smaller, and the second stream costs its entropy
/// coding only (a second walk made bucky 128^3's convert 35 % slower).
template <class T>
struct FieldPointEncoderPair {
    rc::Encoder enc1, enc2;
    FieldModelsOf<false>* models1 = nullptr;
    FieldModelsOf<true>* models2 = nullptr;
    const T* v = nullptr;
    LatticeView lat;

    [[gnu::always_inline]] void operator()(int cls, const Prediction& pr, int64_t idx, int64_t s) {
        using D = Dom<T>;
        const uint64_t mean = lat.neighbour_mean(s);
        const auto r = typename D::S(typename D::U(uint64_t(D::get(v[idx])) - uint64_t(pr.p)));
        const bool neg = r < 0;
        const uint64_t mag = neg ? uint64_t(0) - uint64_t(int64_t(r)) : uint64_t(r);
        rc::encode_int(enc1, models1->m[cls][field_context<false>(cls, pr.spread, mean)], mag, neg, D::W);
        rc::encode_int(enc2, models2->m[cls][field_context<true>(cls, pr.spread, mean)], mag, neg, D::W);
        lat.set(s, mag);
    }
};

/// The streams of modes 0 and 5 of a field chunk (FieldPointEncoderPair).
template <class T>
std::pair<std::vector<std::byte>, std::vector<std::byte>> encode_field_chunk_both(const Geometry& G, const T* v,
                                                                                   const HtChunk& c) {
    std::vector<std::byte> out1, out2;
    if (c.points == 0) return {};
    auto models1 = std::make_unique<FieldModelsOf<false>>();
    auto models2 = std::make_unique<FieldModelsOf<true>>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    prefetch_chunk(G, v, c.cycle, c.box, 1);
    FieldPointEncoderPair<T> step{rc::Encoder(out1), rc::Encoder(out2), models1.get(), models2.get(), v, lat.view()};
    walk_field_chunk(G, v, c, lat, step);
    step.enc1.finish();
    step.enc2.finish();
    return {std::move(out1), std::move(out2)};
}

/// The decoder's step for one point, as a value type: walk_field_chunk keeps
/// a copy in locals for each row, so the range decoder's state and the lattice
/// pointer stay in registers across the stores of decoded values (as members
/// of an object in memory, every u8 store, which may alias anything, forced
/// their reload).
template <class T, bool TwoD = false>
struct FieldPointDecoder {
    rc::Decoder dec;
    FieldModelsOf<TwoD>* models = nullptr;
    T* v = nullptr;
    LatticeView lat;
    RowEvenStrides even;  // of the current row (classes 0..2)

    uint32_t wprev = 0;   // the lattice at the slot of x − 2h (classes 0..2)

    /// s0: the slot of the row's first point.
    void begin_row(const ChunkRow& r, int64_t s0) {
        if (r.cls < 3) {
            even = row_even_strides(r, lat);
            wprev = lat.mag[s0 - 2];
        }
    }

    [[gnu::always_inline]] void operator()(int cls, const Prediction& pr, int64_t idx, int64_t s) {
        using D = Dom<T>;
        if (dec.overrun()) return;  // a valid stream never reads past its end: skip the rest
        // Classes 0..2 read only the neighbours that can be set (same mean),
        // the previous point of the row from a register.
        const uint64_t mean = cls < 3 ? lat.neighbour_mean_in_order_prev(cls, s, even.even1, even.even2, wprev)
                                      : lat.neighbour_mean(s);
        uint64_t mag;
        bool neg;
        rc::decode_int(dec, models->m[cls][field_context<TwoD>(cls, pr.spread, mean)], mag, neg, D::W);
        const typename D::U r = neg ? typename D::U(uint64_t(0) - mag) : typename D::U(mag);
        v[idx] = D::put(typename D::U(uint64_t(pr.p) + uint64_t(r)));
        lat.set(s, mag);
        wprev = LatticeView::stored(mag);
    }
};

/// The first pass of a block of n points of a row of class Cls (n <= kDecodeBlock),
/// from x on (field index idx, lattice slot s): what does not depend on the
/// values the row decodes, per point the prediction, its spread and the sum
/// and count of the neighbours' magnitudes other than the row's previous
/// point. A point of a row of classes 0..2 is predicted from coarser points
/// and points of earlier classes, and its context reads other rows and x ± h
/// (another class): nothing the row itself sets, so this pass sees the values
/// a one-pass walk sees. Shared by the decoders of modes 0, 5 and 6.
constexpr int64_t kDecodeBlock = 64;
template <class T, int Cls>
[[gnu::always_inline]] inline void predict_block(const Geometry& G, const ChunkFrame& Fr, int t, const ChunkRow& r,
                                             const RowPredictor<T, Cls>& P, const LatticeView& lv,
                                             const RowEvenStrides& even, const T* vv, int64_t x, int64_t n,
                                             int64_t idx, int64_t s, int64_t didx, int64_t ds, int64_t* pp,
                                             uint64_t* psp, uint64_t* osum, uint32_t* on) {
    const int64_t xs = r.step;
    int64_t i = 0, xi = x, ii = idx, si = s;
#if defined(__SSE2__)
    if constexpr (std::is_same_v<T, uint8_t>) {
        // u8 rows whose points lie two bytes apart (a chunk's
        // window, or cycle 0 of the whole field): eight predictions
        // at once, in 16-bit lanes (sums of at most 8 · 255 · 1, or
        // 4 · 255 + 2 · 2 · 255, fit), the same sums, shifts and
        // spread as RowPredictor::at. Only where the scalar walk
        // takes at() with the fine stencil too (or class 0), for all
        // eight points and a ninth: a 16-byte load then reads
        // nothing beyond what that ninth point's stencil reads.
        if (didx == 2) {
            const __m128i lo8 = _mm_set1_epi16(0x00FF);
            // Leading points before the fine stencil's range: scalar.
            if constexpr (Cls > 0)
                for (; i < n && xi < P.fine_lo && xi <= P.coarse_hi; ++i, xi += xs, ii += didx, si += ds) {
                    const Prediction pr = P.at(vv, ii, xi);
                    pp[i] = pr.p;
                    psp[i] = pr.spread;
                    const LatticeView::Others o = lv.others_in_order(Cls, si, even.even1, even.even2);
                    osum[i] = o.sum;
                    on[i] = o.n;
                }
            for (; i + 8 <= n; i += 8, xi += 8 * xs, ii += 16, si += 8 * ds) {
                const int64_t xlast = xi + 7 * xs;
                if (xlast > P.coarse_hi) break;
                if (Cls > 0 && (xi < P.fine_lo || xlast > P.fine_hi)) break;
                // The 16 bytes from each stencil point of the first:
                // its byte 15 is read by a ninth point's stencil when
                // there is one (fixed, in the fine range); otherwise
                // the 16 bytes from one before, whose byte 0 the
                // stencil of the point before the first read (the
                // row's previous point, fixed and in the fine range).
                const bool next = i + 8 < n && xlast + xs <= P.coarse_hi &&
                                  (Cls == 0 || xlast + xs <= P.fine_hi);
                const bool prev = i > 0 && (Cls == 0 || xi - xs >= P.fine_lo);
                if (!next && !prev) break;
                auto ld = [&](int k) {
                    const uint8_t* a = vv + ii + P.off[k];
                    return next ? _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a)), lo8)
                                : _mm_srli_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a - 1)), 8);
                };
                __m128i w = ld(0);
                __m128i sum = w, mn = w, mx = w;
                for (int k = 1; k < kCoarseCount<Cls>; ++k) {
                    w = ld(k);
                    sum = _mm_add_epi16(sum, w);
                    mn = _mm_min_epi16(mn, w);
                    mx = _mm_max_epi16(mx, w);
                }
                __m128i p;
                if constexpr (Cls == 0) {
                    p = _mm_srli_epi16(sum, 3);
                } else {
                    __m128i fine = _mm_setzero_si128();
                    for (int k = 0; k < kFineCount<Cls>; ++k) {
                        w = ld(kCoarseCount<Cls> + k);
                        fine = _mm_add_epi16(fine, w);
                        mn = _mm_min_epi16(mn, w);
                        mx = _mm_max_epi16(mx, w);
                    }
                    p = Cls == 1 ? _mm_srli_epi16(_mm_add_epi16(sum, _mm_add_epi16(fine, fine)), 3)
                                 : _mm_srli_epi16(_mm_add_epi16(_mm_add_epi16(sum, sum), fine), 3);
                }
                alignas(16) uint16_t pv[8], sv[8];
                _mm_store_si128(reinterpret_cast<__m128i*>(pv), p);
                _mm_store_si128(reinterpret_cast<__m128i*>(sv), _mm_sub_epi16(mx, mn));
                for (int j = 0; j < 8; ++j) {
                    pp[i + j] = pv[j];
                    psp[i + j] = sv[j];
                    const LatticeView::Others o =
                        lv.others_in_order(Cls, si + j * ds, even.even1, even.even2);
                    osum[i + j] = o.sum;
                    on[i + j] = o.n;
                }
            }
        }
    }
#endif
    for (; i < n; ++i, xi += xs, ii += didx, si += ds) {
        const Prediction pr =
            P.fixed(xi) ? P.at(vv, ii, xi) : predict_v2(G, vv, t, Cls, xi, r.y, r.z, Fr.cb);
        pp[i] = pr.p;
        psp[i] = pr.spread;
        const LatticeView::Others o = lv.others_in_order(Cls, si, even.even1, even.even2);
        osum[i] = o.sum;
        on[i] = o.n;
    }
}

/// walk_field_chunk for FieldPointDecoder, the same points in the same order
/// with the same predictions and contexts, in two passes over blocks of a
/// row: first what does not depend on the values the row decodes (the
/// prediction and its spread, the neighbours' part of the context other than
/// the previous point), then the range decoding. A point of a row of classes
/// 0..2 is predicted from coarser points and points of earlier classes, and
/// its context reads other rows and x ± h (another class): nothing the row
/// itself sets, so the first pass sees the values the one-pass walk saw. The
/// second pass, which carries the coder's dependent chain, then has few
/// values live (in one pass they spilled, and the loop reloaded them per point).
template <class T, bool TwoD>
void decode_field_rows(const Geometry& G, T* v, const HtChunk& c, const ChunkLattice& lat,
                       FieldPointDecoder<T, TwoD>& f) {
    const ChunkFrame Fr(G, c.cycle, c.box);
    const int t = c.cycle;
    for_each_row_v2(G, t, c.box, [&](const ChunkRow& row) {
        dispatch_row_class(row, [&]<int Cls>(const ChunkRow& r) {
            int64_t idx = G.index(r.x0, r.y, r.z);
            int64_t s = lat.slot(r.x0, r.y, r.z);
            const int64_t didx = G.index_delta(r.step, 0, 0), ds = r.step >> t;
            if constexpr (Cls == 3) {
                for (int64_t x = r.x0; x <= r.x1; x += r.step, idx += didx, s += ds) f(Cls, Prediction{}, idx, s);
            } else {
                using D = Dom<T>;
                const RowPredictor<T, Cls> P(G, Fr, r);
                const LatticeView lv = f.lat;
                const RowEvenStrides even = row_even_strides(r, lv);
                rc::Decoder dec = f.dec;
                rc::IntModel* const models = f.models->m[Cls];
                uint32_t wprev = lv.mag[s - 2];
                constexpr int64_t kBlock = kDecodeBlock;
                // Plain arrays, not Prediction / Others (whose member
                // initializers made every row clear them).
                int64_t pp[kBlock];
                uint64_t psp[kBlock], osum[kBlock];
                uint32_t on[kBlock];
                T* const vv = v;  // a local: the field pointer was reloaded after every store
                const int64_t x1 = r.x1, xs = r.step;
                for (int64_t x = r.x0; x <= x1;) {
                    const int64_t n = std::min<int64_t>(kBlock, (x1 - x) / xs + 1);
                    predict_block<T, Cls>(G, Fr, t, r, P, lv, even, vv, x, n, idx, s, didx, ds, pp, psp, osum, on);
                    for (int64_t i = 0; i < n; ++i, idx += didx, s += ds) {
                        if (dec.overrun()) continue;  // a valid stream never reads past its end: skip the rest
                        const uint64_t mean = LatticeView::mean_with_prev(LatticeView::Others{osum[i], on[i]}, wprev);
                        uint64_t mag;
                        bool neg;
                        rc::decode_int(dec, models[field_context<TwoD>(Cls, psp[i], mean)], mag, neg, D::W);
                        const typename D::U rr = neg ? typename D::U(uint64_t(0) - mag) : typename D::U(mag);
                        vv[idx] = D::put(typename D::U(uint64_t(pp[i]) + uint64_t(rr)));
                        lv.set(s, mag);
                        wprev = LatticeView::stored(mag);
                    }
                    x += n * xs;
                }
                f.dec = dec;
            }
        });
    });
}

/// False on a malformed stream. TwoD: mode 5's contexts (range-2d).
template <class T, bool TwoD = false>
bool decode_field_chunk_v2(const Geometry& G, T* v, const HtChunk& c, std::span<const std::byte> in) {
    if (c.points == 0) return in.empty();
    auto models = std::make_unique<FieldModelsOf<TwoD>>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    FieldPointDecoder<T, TwoD> step{rc::Decoder(in.data(), in.size()), models.get(), v, lat.view(), {}, 0};
    decode_field_rows(G, v, c, lat, step);
    return !step.dec.bad_end();
}

}  // namespace tetlod::ht_detail
