#pragma once
// Residual coding 2, error chunks (spec §8.3): quantized error codes coded
// against the bound the lattice of the diamond allows.

#include "ht_chunk_rows.hpp"

namespace tetlod::ht_detail {

struct ErrorModels {
    rc::Bit inf[4][2];  // class 3 (corners) never used: corners are not diamonds
    rc::IntModel m[4][2][6];
};

/// Spec §8.4 (chunk mode 7, format 3.8): the lattice bound's exponent picks
/// the context. Bucket 0 is a zero bound; 1 .. kErrorBuckets-1 the bound's
/// exponent from the chunk's base E0 on (below E0 shares bucket 1, above
/// the last shares the last). How far a diamond's error exceeds what its
/// lattice shows depends on the scale of the detail there.
constexpr int kErrorBuckets = 24;
struct ErrorModelsExp {
    rc::Bit inf[4][2];
    rc::ShortIntModel m[4][kErrorBuckets][4];
    rc::MantissaModel mant[kErrorBuckets];
};
inline int error_bucket(uint32_t lb, int m, int e0) {
    if (lb == 0) return 0;
    return 1 + std::clamp(int(lb >> m) - e0, 0, kErrorBuckets - 2);
}
/// Spec §8.3: may the diamond centred at c have a tet outside B (then it may be +inf)?
inline int touches_far_face(const Geometry& G, int t, int64_t x, int64_t y, int64_t z) {
    const int64_t h = int64_t{1} << t;
    return (x + h > G.box_max[0] || y + h > G.box_max[1] || z + h > G.box_max[2]) ? 1 : 0;
}

/// Spec §8.3: the lattice lower bound of a diamond's error. Over the tets of the
/// diamond with all four vertices in B, and over their edges (a, b) whose
/// midpoint p lies on the lattice of spacing h = 2^t, the largest
/// |f(p) - (f(a) + f(b)) / 2| (L_T(p) at an edge midpoint), counting only
/// points already decoded: coarser cycles, or cycle t inside the chunk's box.
/// At cycle 0 every grid point of the tets is such a midpoint or a vertex, so
/// the bound is the exact diamond error unless a point lies in another brick.
template <class T>
uint32_t lattice_bound_code(const Geometry& G, const T* v, int t, int64_t x, int64_t y, int64_t z,
                            const std::array<int64_t, 6>& cb, int m) {
    const ht::Pt c{int32_t(x), int32_t(y), int32_t(z)};
    const ht::DiamondInfo di = ht::classify_centre(c, G.k);
    ht::Tet tets[8];
    const int n = ht::diamond_tets(c, di, int32_t(int64_t{1} << G.k), tets);
    const int64_t h = int64_t{1} << t;
    auto known = [&](const ht::Pt& p) {
        bool coarse = true;
        for (int a = 0; a < 3; ++a) {
            if (p[a] < 0 || p[a] > G.box_max[a]) return false;
            if (p[a] & h) coarse = false;
        }
        if (coarse) return true;
        for (int a = 0; a < 3; ++a)
            if (p[a] < cb[a] || p[a] > cb[3 + a]) return false;
        return true;
    };
    static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    double best = 0.0;
    for (int i = 0; i < n; ++i) {
        const ht::Tet& T4 = tets[i];
        bool inside = true;
        for (const auto& p : T4)
            for (int a = 0; a < 3; ++a) inside = inside && p[a] >= 0 && p[a] <= G.box_max[a];
        if (!inside) continue;
        for (const auto& e : kEdges) {
            const ht::Pt& a = T4[e[0]];
            const ht::Pt& b = T4[e[1]];
            ht::Pt p;
            bool lattice = true;
            for (int q = 0; q < 3; ++q) {
                const int64_t s2 = int64_t(a[q]) + b[q];
                if ((s2 & (2 * h - 1)) != 0) lattice = false;
                p[q] = int32_t(s2 / 2);
            }
            if (!lattice || !known(p) || !known(a) || !known(b)) continue;
            const double fa = static_cast<double>(v[G.index(a[0], a[1], a[2])]);
            const double fb = static_cast<double>(v[G.index(b[0], b[1], b[2])]);
            const double fp = static_cast<double>(v[G.index(p[0], p[1], p[2])]);
            const double d = std::fabs(fp - 0.5 * (fa + fb));
            if (!(d <= best) && !std::isnan(best)) best = d;  // a NaN wins and stays
        }
    }
    return quantize_error(static_cast<float>(best), m);
}

/// lattice_bound_code for a diamond inside B (c ± h in B) near its chunk's
/// faces: the closed-form edge list, skipping edges with a point that is not
/// available (neither coarser than cycle t nor in the chunk's box).
template <class T>
uint32_t lattice_bound_near_face(const T* c, const DiamondEdges& E, const int64_t off[27], uint32_t avail, int m) {
    double best = 0.0;
    for (int i = 0; i < E.n; ++i) {
        if (!((avail >> E.a[i]) & (avail >> E.b[i]) & (avail >> E.m[i]) & 1u)) continue;
        const double fa = static_cast<double>(c[off[E.a[i]]]);
        const double fb = static_cast<double>(c[off[E.b[i]]]);
        const double fp = static_cast<double>(c[off[E.m[i]]]);
        const double d = std::fabs(fp - 0.5 * (fa + fb));
        if (std::isnan(d)) return quantize_error(std::numeric_limits<float>::quiet_NaN(), m);
        best = std::max(best, d);
    }
    return quantize_error(static_cast<float>(best), m);
}

/// The lattice edges of every sign pattern (DiamondEdgeTable) as field offsets
/// from the centre (midpoint, end, end), for one chunk frame, so an interior
/// diamond's bound reads its values without the indirection through the 27
/// neighbour offsets (a third of an error chunk's decoding was that bound).
class InteriorEdgeOffsets {
public:
    explicit InteriorEdgeOffsets(const ChunkFrame& F) {
        const DiamondEdgeTable& table = diamond_edge_table();
        for (int sig = 0; sig < 27; ++sig) {
            const DiamondEdges& E = table.by_sig[sig];
            first_[sig] = uint16_t(off_.size() / 3);
            for (int i = 0; i < E.n; ++i) {
                off_.push_back(F.off[E.m[i]]);
                off_.push_back(F.off[E.a[i]]);
                off_.push_back(F.off[E.b[i]]);
            }
        }
        first_[27] = uint16_t(off_.size() / 3);
    }
    /// The edges of sign pattern `sig`: count and (midpoint, a, b) triples.
    int count(int sig) const { return first_[sig + 1] - first_[sig]; }
    const int64_t* triples(int sig) const { return off_.data() + 3 * std::size_t(first_[sig]); }

private:
    std::vector<int64_t> off_;
    uint16_t first_[28]{};
};

/// lattice_bound_code for a diamond in the chunk interior (ChunkFrame::interior):
/// all its tets are in B and every point they touch is available, so the scan
/// is the closed-form edge list of its sign pattern (InteriorEdgeOffsets).
/// For integer types |f(m) - (f(a) + f(b))/2| = |2 f(m) - f(a) - f(b)| / 2 exactly.
template <class T>
[[gnu::always_inline]] inline uint32_t lattice_bound_interior(const T* c, const int64_t* tri, int n, int m) {
    if constexpr (std::is_integral_v<T>) {
        int64_t best = 0;
        for (int i = 0; i < n; ++i, tri += 3) {
            const int64_t d = 2 * int64_t(c[tri[0]]) - int64_t(c[tri[1]]) - int64_t(c[tri[2]]);
            best = std::max(best, d < 0 ? -d : d);
        }
        return quantize_error(static_cast<float>(double(best) * 0.5), m);
    } else {
        double best = 0.0;
        for (int i = 0; i < n; ++i, tri += 3) {
            const double d = std::fabs(static_cast<double>(c[tri[0]]) -
                                       0.5 * (static_cast<double>(c[tri[1]]) + static_cast<double>(c[tri[2]])));
            if (std::isnan(d)) return quantize_error(std::numeric_limits<float>::quiet_NaN(), m);
            best = std::max(best, d);
        }
        return quantize_error(static_cast<float>(best), m);
    }
}

/// lattice_bound_code for a diamond outside the chunk interior (interior ones
/// take lattice_bound_interior): near the chunk's faces the closed-form edges
/// with the points available, beyond B's faces the general scan.
template <class T>
uint32_t lattice_bound_at_faces(const Geometry& G, const T* v, const ChunkFrame& F, int t, int64_t x, int64_t y,
                                int64_t z, int64_t idx, int m) {
    const DiamondEdges& E = diamond_edge_table().by_sig[sig_code(x, y, z, F.h)];
    const int64_t h = F.h;
    const int64_t c[3] = {x, y, z};
    bool in_b = true;
    for (int a = 0; a < 3; ++a) in_b = in_b && c[a] - h >= 0 && c[a] + h <= G.box_max[a];
    if (!in_b) return lattice_bound_code(G, v, t, x, y, z, F.cb, m);
    // Per axis and offset o in {-1, 0, 1}: coarse (even multiple of h) and in the chunk's box.
    bool even[3][3], inside[3][3];
    for (int a = 0; a < 3; ++a)
        for (int o = -1; o <= 1; ++o) {
            const int64_t p = c[a] + o * h;
            even[a][o + 1] = (p & h) == 0;
            inside[a][o + 1] = p >= F.cb[a] && p <= F.cb[3 + a];
        }
    uint32_t avail = 0;
    for (int oz = 0; oz < 3; ++oz)
        for (int oy = 0; oy < 3; ++oy)
            for (int ox = 0; ox < 3; ++ox)
                if ((even[0][ox] && even[1][oy] && even[2][oz]) || (inside[0][ox] && inside[1][oy] && inside[2][oz]))
                    avail |= 1u << (ox + 3 * oy + 9 * oz);
    return lattice_bound_near_face(v + idx, E, F.off, avail, m);
}

/// What both error coders work out once per row (for_each_row_v2): along a
/// row only x moves, by 2h, so the field index and the lattice slot advance by
/// constants, the far-face and interior tests are x ranges, and an interior
/// diamond's edges alternate between two sign patterns (only x's changes).
struct ErrorRow {
    int64_t far_from;                // touches_far_face for x > far_from
    ChunkFrame::XRange interior;     // ChunkFrame::interior
    const int64_t* tri[2];           // InteriorEdgeOffsets of the two patterns
    int ntri[2];
    int64_t idx, didx, slot, dslot;  // field index and lattice slot of x, and their steps
    int parity = 0;                  // which pattern x has

    ErrorRow(const Geometry& G, const ChunkFrame& F, const ChunkLattice& lat, const InteriorEdgeOffsets& edges, int t,
             const ChunkRow& r)
        : far_from(touches_far_face(G, t, r.x0, r.y, r.z) ? r.x0 - 1 : G.box_max[0] - F.h),
          interior(F.interior_x(r.y, r.z)), idx(G.index(r.x0, r.y, r.z)), didx(G.index_delta(r.step, 0, 0)),
          slot(lat.slot(r.x0, r.y, r.z)), dslot(r.step >> t) {
        const int sig[2] = {sig_code(r.x0, r.y, r.z, F.h), sig_code(r.x0 + r.step, r.y, r.z, F.h)};
        for (int p = 0; p < 2; ++p) tri[p] = edges.triples(sig[p]), ntri[p] = edges.count(sig[p]);
    }
    void next() { idx += didx, slot += dslot, parity ^= 1; }
    /// The lattice bound code of the diamond at (x, r.y, r.z), the current point.
    template <class T>
    uint32_t bound(const Geometry& G, const T* v, const ChunkFrame& F, int t, int64_t x, const ChunkRow& r,
                   int m) const {
        return interior.contains(x) ? lattice_bound_interior(v + idx, tri[parity], ntri[parity], m)
                                    : lattice_bound_at_faces(G, v, F, t, x, r.y, r.z, idx, m);
    }
};

/// What the coders of §8.3 and §8.4 code for one diamond, in the chunk's class
/// order: both code the same Inf bits and the same residuals q - lb against the
/// same lattice bounds and neighbours' magnitudes; only their models differ. The
/// writer tries both on every error chunk, so the walk that finds these (the
/// lattice bounds: a third of the error coding's time) runs once.
struct ErrorSymbol {
    uint16_t lb;      // lattice bound code (meaningless with kInf)
    uint16_t mag;     // |q - lb|
    uint8_t cls;
    uint8_t nbl;      // bit length of the neighbours' mean magnitude
    uint8_t flags;    // kFar | kInf | kNeg
    static constexpr uint8_t kFar = 1, kInf = 2, kNeg = 4;
    uint32_t code() const { return (flags & kNeg) ? uint32_t(lb) - mag : uint32_t(lb) + mag; }
};

/// The chunk's ErrorSymbols (spec §8.3: Inf bit, lattice bound, residual and
/// neighbours' magnitude of every diamond, in class order).
template <class T>
void gather_error_symbols(const Geometry& G, const T* v, std::span<const float> e, const HtChunk& c, int m,
                          std::vector<ErrorSymbol>& out) {
    out.clear();
    if (c.diamonds == 0) return;
    out.resize(std::size_t(c.diamonds));  // one a diamond (the walk stops at the chunk's count)
    ErrorSymbol* o = out.data();
    ErrorSymbol* const end = o + out.size();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    const uint32_t qmax = max_error_code(m);
    // Cycle 0 inside the chunk: every grid point of the diamond's tets is a
    // vertex or the midpoint of one of their edges, all available, so the
    // lattice bound is the diamond's exact error; for types of up to 16 bits
    // both are exact halves of integers, hence the same float and the same
    // code q. The decoder computes the bound; the encoder (7/8 of the diamonds
    // are of cycle 0) need not. The round-trip tests check it on every type.
    const bool bound_is_error = c.cycle == 0 && std::is_integral_v<T> && sizeof(T) <= 2;
    prefetch_chunk(G, e.data(), c.cycle, c.box, 0);
    if (!bound_is_error) prefetch_chunk(G, v, c.cycle, c.box, 1);
    // Row by row (the order of for_each_point_v2), with what ErrorRow works out
    // once a row; the deep-interior test is an x range too.
    const LatticeView L = lat.view();
    const InteriorEdgeOffsets interior_edges(F);
    for_each_row_v2(G, c.cycle, c.box, [&](const ChunkRow& r) {
        const uint8_t cls = uint8_t(r.cls);
        ErrorRow row(G, F, lat, interior_edges, c.cycle, r);
        const ChunkFrame::XRange deep = F.deep_interior_x(r.y, r.z);
        for (int64_t x = r.x0; x <= r.x1; x += r.step, row.next()) {
            if (o == end) return;  // never for a consistent chunk; no write past the array
            const int64_t s = row.slot;
            const uint8_t far = x > row.far_from ? ErrorSymbol::kFar : 0;
            const uint32_t q = quantize_error(e[std::size_t(row.idx)], m);
            if (q == qmax) {
                *o++ = ErrorSymbol{0, 0, cls, 0, uint8_t(far | ErrorSymbol::kInf)};
                L.set(s, 0);
                continue;
            }
            if (bound_is_error && row.interior.contains(x)) {
                // q equals its bound: a zero residual. Its neighbours' residuals are
                // zero too when they are all interior, so their mean is 0 unread.
                const int nb = deep.contains(x) ? 0 : rc::bit_length(L.neighbour_mean(s));
                *o++ = ErrorSymbol{uint16_t(q), 0, cls, uint8_t(nb), far};
                L.set(s, 0);
                continue;
            }
            const uint32_t lb = row.bound(G, v, F, c.cycle, x, r, m);
            const int64_t delta = int64_t(q) - int64_t(lb);
            const uint32_t mag = uint32_t(delta < 0 ? -delta : delta);
            *o++ = ErrorSymbol{uint16_t(lb), uint16_t(mag), cls, uint8_t(rc::bit_length(L.neighbour_mean(s))),
                               uint8_t(far | (delta < 0 ? ErrorSymbol::kNeg : 0))};
            L.set(s, mag);
        }
    });
    out.resize(std::size_t(o - out.data()));
}

/// The error chunk's stream from its symbols. Exp: chunk mode 7 (§8.4), the
/// exponent contexts; else mode 0 (§8.3).
template <bool Exp = false>
std::vector<std::byte> code_error_symbols(std::span<const ErrorSymbol> sym, int m) {
    std::vector<std::byte> out;
    if (sym.empty()) return out;
    using Models = std::conditional_t<Exp, ErrorModelsExp, ErrorModels>;
    auto models = std::make_unique<Models>();
    int e0 = 0;
    if constexpr (Exp) {
        // The top kErrorBuckets-1 exponents of the chunk's finite codes get a
        // bucket each (the bounds are at most the codes, nearly always).
        uint32_t top = 0;
        for (const ErrorSymbol& d : sym)
            if (!(d.flags & ErrorSymbol::kInf)) top = std::max(top, d.code() >> m);
        e0 = std::max(0, int(top) - (kErrorBuckets - 2));
        out.push_back(std::byte(e0));
    }
    rc::Encoder enc(out);
    for (const ErrorSymbol& d : sym) {
        const bool inf = (d.flags & ErrorSymbol::kInf) != 0;
        enc.encode(models->inf[d.cls][d.flags & ErrorSymbol::kFar], inf);
        if (inf) continue;
        const bool neg = (d.flags & ErrorSymbol::kNeg) != 0;
        if constexpr (Exp) {
            const int g = error_bucket(d.lb, m, e0);
            rc::encode_short_int(enc, models->m[d.cls][g][std::min<int>(3, d.nbl)], models->mant[g], d.mag, neg);
        } else {
            rc::encode_int(enc, models->m[d.cls][d.lb != 0][std::min<int>(5, d.nbl)], d.mag, neg, 16);
        }
    }
    enc.finish();
    return out;
}

/// False on a malformed stream or a code out of range. Exp: mode 7 (§8.4).
template <class T, bool Exp = false>
bool decode_error_chunk_v2(const Geometry& G, const T* v, float* e, const HtChunk& c, int m,
                           std::span<const std::byte> in) {
    if (c.diamonds == 0) return in.empty();
    using Models = std::conditional_t<Exp, ErrorModelsExp, ErrorModels>;
    auto models = std::make_unique<Models>();
    int e0 = 0;
    if constexpr (Exp) {
        if (in.empty()) return false;
        e0 = std::to_integer<int>(in[0]);
        in = in.subspan(1);
    }
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    rc::Decoder dec(in.data(), in.size());
    const uint32_t qmax = max_error_code(m);
    bool ok = true;
    // Row by row as gather_error_symbols (ErrorRow): the same decisions in the
    // same order as a point-by-point walk.
    const LatticeView L = lat.view();
    const InteriorEdgeOffsets interior_edges(F);
    for_each_row_v2(G, c.cycle, c.box, [&](const ChunkRow& r) {
        const int cls = r.cls;
        ErrorRow row(G, F, lat, interior_edges, c.cycle, r);
        for (int64_t x = r.x0; x <= r.x1; x += r.step, row.next()) {
            if (dec.overrun()) return;  // a valid stream never reads past its end: stop early
            const int64_t s = row.slot;
            const int far = x > row.far_from ? 1 : 0;
            float& out = e[row.idx];
            if (dec.decode(models->inf[cls][far])) {
                out = std::numeric_limits<float>::infinity();
                L.set(s, 0);
                continue;
            }
            const uint32_t lb = row.bound(G, v, F, c.cycle, x, r, m);
            const int nbl = rc::bit_length(L.neighbour_mean(s));
            uint64_t mag;
            bool neg;
            if constexpr (Exp) {
                const int g = error_bucket(lb, m, e0);
                uint32_t mag32;
                rc::decode_short_int(dec, models->m[cls][g][std::min(3, nbl)], models->mant[g], mag32, neg);
                mag = mag32;
            } else {
                rc::decode_int(dec, models->m[cls][lb != 0][std::min(5, nbl)], mag, neg, 16);
            }
            const int64_t q = int64_t(lb) + (neg ? -int64_t(mag) : int64_t(mag));
            if (q < 0 || q >= int64_t(qmax) || (neg && mag == 0)) {
                ok = false;
                out = std::numeric_limits<float>::infinity();
            } else {
                out = dequantize_error(uint16_t(q), m);
            }
            L.set(s, mag);
        }
    });
    return ok && !dec.bad_end();
}

}  // namespace tetlod::ht_detail
