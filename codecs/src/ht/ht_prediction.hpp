#pragma once
// Residual coding 2 (spec §7.3-§7.5): the chunk lattice, the diamonds' edges and
// the coarse-to-fine predictors shared by the field and error chunk coders.

#include "ht_chunk_geometry.hpp"

namespace tetlod::ht_detail {

// ---- residual coding 2 (spec §7.3-§7.5, §8.3): class-ordered chunks, adaptive range coder ----

/// Activity bucket of spec §7.5: bit length, compressed above 8.
[[gnu::always_inline]] inline int activity_bucket(uint64_t a) {
    const int bl = rc::bit_length(a);
    return bl <= 8 ? bl : std::min(15, 8 + (bl - 6) / 3);
}

/// The magnitudes of a ChunkLattice (saturated magnitude + 1, 0 = unset) at
/// `mag`, with its row and plane strides.
struct LatticeView {
    uint32_t* mag = nullptr;
    int64_t px = 0, pxy = 0;
    [[gnu::always_inline]] void set(int64_t s, uint64_t m) const {
        mag[s] = uint32_t(std::min<uint64_t>(m, 0xFFFFFFFEu) + 1);
    }
    /// Spec §7.6: mean magnitude of the already coded lattice neighbours among
    /// (x±h), (y±h), (z±h), (x−2h), (y−2h), (z−2h) (integer division; 0 if none).
    [[gnu::always_inline]] uint64_t neighbour_mean(int64_t s) const {
        const uint32_t* q = mag + s;
        return mean_of_set(q[-1], q[1], q[-px], q[px], q[-pxy], q[pxy], q[-2], q[-2 * px], q[-2 * pxy]);
    }
    /// neighbour_mean(s) without x − 2h, the row's previous point: the context
    /// of chunk mode 6 (spec §7.6, "Static tables"), which a decoder works out
    /// for a whole block of a row before decoding it. For a point of class 0..2
    /// it equals mean_of(others_in_order(...)) (unset slots hold 0).
    [[gnu::always_inline]] uint64_t neighbour_mean_without_prev(int64_t s) const {
        const uint32_t* q = mag + s;
        return mean_of_set(q[-1], q[1], q[-px], q[px], q[-pxy], q[pxy], q[-2 * px], q[-2 * pxy]);
    }
    /// The mean magnitude of the set slots among lattice values `w` (sat(mag)
    /// + 1, 0 unset): the sum of (w - 1) over the set ones is the sum of w less
    /// their count.
    template <class... W>
    [[gnu::always_inline]] static uint64_t mean_of_set(W... w) {
        const uint64_t sum = (uint64_t(w) + ...);
        const uint32_t n = (uint32_t(w != 0) + ...);
        return mean_of(sum - n, n);
    }
    /// floor(sum / n), 0 when sum is 0 (n may then be 0). Most neighbourhoods
    /// are all zero residuals, and the rest small: a multiply by the reciprocal
    /// instead of a division, which was the largest single cost of the mean in
    /// the decoder's profile.
    [[gnu::always_inline]] static uint64_t mean_of(uint64_t sum, uint32_t n) {
        if (sum == 0) return 0;
        if (sum < kReciprocalLimit) return (sum * kReciprocal[n]) >> kReciprocalShift;
        return sum / n;
    }
    /// neighbour_mean(s) for a point of class cls < 3 of a field chunk's
    /// coding order 2, reading only the neighbours that can be set by then.
    /// Along one axis ±h flips that axis's parity, so the neighbour has one
    /// odd axis more or fewer: for class 0 (3 odd axes) a class-1 point, coded
    /// after it; for class 1 a class-0 point across its even axis (coded) and
    /// a class-2 point across an odd one (not yet); for class 2 class-1 points
    /// across its even axes and a coarser point (never set in this lattice)
    /// across its odd one. The −2h neighbours keep the class and may be set.
    /// Unset slots hold 0 and add nothing to the sum or the count, so the
    /// result is neighbour_mean(s)'s; even1/even2 are the lattice strides of
    /// the row's even axes (RowEvenStrides). Fewer loads per point: the decoder
    /// spends its time per point, and this was 9 loads of mostly zeros.
    [[gnu::always_inline]] uint64_t neighbour_mean_in_order(int cls, int64_t s, int64_t even1,
                                                            int64_t even2) const {
        return mean_with_prev(others_in_order(cls, s, even1, even2), mag[s - 2]);
    }
    /// neighbour_mean_in_order(cls, s, even1, even2) with the slot of x − 2h
    /// (the previous point of the row: rows of classes 0..2 step by 2h, two
    /// slots) given as `wprev`, its value in the lattice (sat(mag) + 1, or 0
    /// when unset), instead of loaded. Same sum and count, so the same mean.
    /// The decoders keep it in a register: it is the only neighbour that
    /// depends on the point decoded just before, and through the store and
    /// reload of the lattice it was on every point's critical path; the sum
    /// and count of the others are ready before that point is decoded.
    [[gnu::always_inline]] uint64_t neighbour_mean_in_order_prev(int cls, int64_t s, int64_t even1, int64_t even2,
                                                                 uint32_t wprev) const {
        return mean_with_prev(others_in_order(cls, s, even1, even2), wprev);
    }
    /// The part of neighbour_mean_in_order_prev that does not depend on the
    /// previous point of the row: the other neighbours' sum of magnitudes and
    /// how many are set. None of them is a point of the row (they lie on other
    /// rows, or at x ± h, another class), so it can be worked out for a whole
    /// row before the row is decoded.
    struct Others {
        uint64_t sum = 0;
        uint32_t n = 0;
    };
    [[gnu::always_inline]] Others others_in_order(int cls, int64_t s, int64_t even1, int64_t even2) const {
        const uint32_t* q = mag + s;
        uint64_t so = uint64_t(q[-2 * px]) + q[-2 * pxy];
        uint32_t no = uint32_t(q[-2 * px] != 0) + uint32_t(q[-2 * pxy] != 0);
        if (cls >= 1) {
            so += uint64_t(q[-even1]) + q[even1];
            no += uint32_t(q[-even1] != 0) + uint32_t(q[even1] != 0);
        }
        if (cls >= 2) {
            so += uint64_t(q[-even2]) + q[even2];
            no += uint32_t(q[-even2] != 0) + uint32_t(q[even2] != 0);
        }
        return Others{so - no, no};
    }
    /// neighbour_mean_in_order_prev from others_in_order and the previous point's lattice value.
    [[gnu::always_inline]] static uint64_t mean_with_prev(const Others& o, uint32_t wprev) {
        const uint32_t pn = uint32_t(wprev != 0);
        return mean_of(o.sum + wprev - pn, o.n + pn);
    }
    /// The lattice value set() stores for magnitude m.
    [[gnu::always_inline]] static uint32_t stored(uint64_t m) { return uint32_t(std::min<uint64_t>(m, 0xFFFFFFFEu) + 1); }
    /// floor(x / n) = (x · ceil(2^37 / n)) >> 37 for x < 2^26 and 1 <= n <= 9:
    /// the product is x / n plus less than x / 2^37 < 2^-11, and the fraction
    /// of x / n is at most (n - 1) / n, which leaves 1 / n > 2^-11 of margin;
    /// x · ceil(2^37 / n) < 2^63 (tests/format/test_ht_neighbour_mean.cpp checks
    /// every x below the limit for every n).
    static constexpr int kReciprocalShift = 37;
    static constexpr uint64_t kReciprocalLimit = uint64_t{1} << 26;
    static constexpr uint64_t kReciprocal[10] = {
        0, (uint64_t{1} << 37) / 1, ((uint64_t{1} << 37) + 1) / 2, ((uint64_t{1} << 37) + 2) / 3,
        ((uint64_t{1} << 37) + 3) / 4, ((uint64_t{1} << 37) + 4) / 5, ((uint64_t{1} << 37) + 5) / 6,
        ((uint64_t{1} << 37) + 6) / 7, ((uint64_t{1} << 37) + 7) / 8, ((uint64_t{1} << 37) + 8) / 9};
};

/// Lattice of a chunk's box at spacing h: per point a saturated magnitude + 1
/// (0 = not coded yet in this chunk), for the neighbour contexts. The lattice
/// carries a border of 2 cells below and 1 above on every axis that is never
/// set, so the neighbour lookups of spec §7.6 need no bounds checks.
struct ChunkLattice {
    int t = 0;
    int64_t x0 = 0, y0 = 0, z0 = 0;
    int64_t px = 0, pxy = 0;  // strides of the padded lattice
    std::vector<uint32_t>& mag;
    ChunkLattice(int cycle, const std::array<int64_t, 6>& b, std::vector<uint32_t>& storage)
        : t(cycle), mag(storage) {
        const int64_t h = int64_t{1} << t;
        auto up = [&](int64_t v) { return (v + h - 1) / h * h; };
        x0 = up(b[0]);
        y0 = up(b[1]);
        z0 = up(b[2]);
        const int64_t nx = b[3] >= x0 ? (b[3] - x0) / h + 1 : 0;
        const int64_t ny = b[4] >= y0 ? (b[4] - y0) / h + 1 : 0;
        const int64_t nz = b[5] >= z0 ? (b[5] - z0) / h + 1 : 0;
        px = nx + 3;
        pxy = px * (ny + 3);
        mag.assign(std::size_t(pxy * (nz + 3)), 0);
    }
    /// Slot of a point of the chunk (on the lattice, inside the box).
    int64_t slot(int64_t x, int64_t y, int64_t z) const {
        return (((z - z0) >> t) + 2) * pxy + (((y - y0) >> t) + 2) * px + ((x - x0) >> t) + 2;
    }
    /// The magnitudes as a plain pointer and strides: a coder copies it into
    /// locals, where no store of a decoded value (a u8 store may alias
    /// anything) forces its reload.
    LatticeView view() const { return LatticeView{mag.data(), px, pxy}; }
    // Inlined as LatticeView's: the error coders call these once per diamond,
    // and out of line they were 3-4% of an encode.
    [[gnu::always_inline]] void set(int64_t s, uint64_t m) { view().set(s, m); }
    [[gnu::always_inline]] uint64_t neighbour_mean(int64_t s) const { return view().neighbour_mean(s); }
};

/// Offsets of the 27 points c + h·(ox, oy, oz), o in {-1, 0, 1}^3, coded as
/// (ox+1) + 3(oy+1) + 9(oz+1).
constexpr int nb27(int ox, int oy, int oz) { return (ox + 1) + 3 * (oy + 1) + 9 * (oz + 1); }

/// Closed form of the edge scan of spec §8.3 for a diamond whose tets lie in the
/// chunk's box: the distinct edges (a, b) of its tets with their midpoint m on
/// the h-lattice, as 27-neighbour indices. The set depends only on the sign
/// pattern sig of §2 (0 on the even axes), which also fixes the class.
struct DiamondEdges {
    uint8_t n = 0;
    uint8_t a[48], b[48], m[48];
};
struct DiamondEdgeTable {
    DiamondEdges by_sig[27];
    DiamondEdgeTable() {
        static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
        for (int code = 0; code < 27; ++code) {
            const int sig[3] = {code % 3 - 1, code / 3 % 3 - 1, code / 9 - 1};
            if (sig[0] == 0 && sig[1] == 0 && sig[2] == 0) continue;
            // A representative centre of cycle 0 in [0, 16]^3: an odd axis with
            // sig = +1 is 3 ((3 + 1) mod 4 = 0), with sig = -1 is 1; an even axis is 2.
            ht::Pt c;
            for (int a = 0; a < 3; ++a) c[a] = sig[a] == 0 ? 2 : (sig[a] > 0 ? 3 : 1);
            ht::Tet tets[8];
            const int nt = ht::diamond_tets(c, ht::classify_centre(c, 4), 16, tets);
            DiamondEdges& E = by_sig[code];
            for (int i = 0; i < nt; ++i)
                for (const auto& e : kEdges) {
                    int oa[3], ob[3];
                    bool lattice = true;
                    for (int q = 0; q < 3; ++q) {
                        oa[q] = tets[i][e[0]][q] - c[q];
                        ob[q] = tets[i][e[1]][q] - c[q];
                        lattice = lattice && ((oa[q] + ob[q]) & 1) == 0;
                    }
                    if (!lattice) continue;
                    int ia = nb27(oa[0], oa[1], oa[2]), ib = nb27(ob[0], ob[1], ob[2]);
                    if (ia > ib) std::swap(ia, ib);
                    bool seen = false;
                    for (int j = 0; j < E.n; ++j) seen = seen || (E.a[j] == ia && E.b[j] == ib);
                    if (seen) continue;
                    E.a[E.n] = uint8_t(ia);
                    E.b[E.n] = uint8_t(ib);
                    E.m[E.n] = uint8_t(nb27((oa[0] + ob[0]) / 2, (oa[1] + ob[1]) / 2, (oa[2] + ob[2]) / 2));
                    ++E.n;
                }
        }
    }
};
inline const DiamondEdgeTable& diamond_edge_table() {
    static const DiamondEdgeTable table;
    return table;
}

/// Sign pattern code (index into DiamondEdgeTable) of a diamond centre of cycle t.
inline int sig_code(int64_t x, int64_t y, int64_t z, int64_t h) {
    auto sg = [h](int64_t v) { return (v & h) == 0 ? 1 : (((v + h) & (4 * h - 1)) == 0 ? 2 : 0); };
    return sg(x) + 3 * sg(y) + 9 * sg(z);
}

/// Per chunk: the linear field offsets of the 27 neighbours at spacing h, and
/// the test for the chunk interior (c ± h inside the chunk's box, which lies in
/// B), where every point a predictor or the lattice bound reads is available.
struct ChunkFrame {
    int64_t h = 1;
    std::array<int64_t, 6> cb{};
    int64_t off[27]{};
    ChunkFrame(const Geometry& G, int t, const std::array<int64_t, 6>& box) : h(int64_t{1} << t), cb(box) {
        for (int oz = -1; oz <= 1; ++oz)
            for (int oy = -1; oy <= 1; ++oy)
                for (int ox = -1; ox <= 1; ++ox)
                    off[nb27(ox, oy, oz)] = G.index_delta(ox * h, oy * h, oz * h);
    }
    bool interior(int64_t x, int64_t y, int64_t z) const {
        return x - h >= cb[0] && y - h >= cb[1] && z - h >= cb[2] && x + h <= cb[3] && y + h <= cb[4] &&
               z + h <= cb[5];
    }
    /// Interior, and so is every lattice neighbour of ChunkLattice::neighbour_mean
    /// that lies in the box: x - 3h .. x + 2h inside the box on every axis.
    bool deep_interior(int64_t x, int64_t y, int64_t z) const {
        return x - 3 * h >= cb[0] && y - 3 * h >= cb[1] && z - 3 * h >= cb[2] && x + 2 * h <= cb[3] &&
               y + 2 * h <= cb[4] && z + 2 * h <= cb[5];
    }
    /// The x values of a row (y, z) for which interior() / deep_interior() hold, so
    /// that a row walk tests a range instead of six bounds per point.
    struct XRange {
        int64_t lo, hi;  // empty when lo > hi
        bool contains(int64_t x) const { return x >= lo && x <= hi; }
    };
    XRange interior_x(int64_t y, int64_t z) const {
        const bool yz = y - h >= cb[1] && z - h >= cb[2] && y + h <= cb[4] && z + h <= cb[5];
        return yz ? XRange{cb[0] + h, cb[3] - h} : XRange{1, 0};
    }
    XRange deep_interior_x(int64_t y, int64_t z) const {
        const bool yz = y - 3 * h >= cb[1] && z - 3 * h >= cb[2] && y + 2 * h <= cb[4] && z + 2 * h <= cb[5];
        return yz ? XRange{cb[0] + 3 * h, cb[3] - 2 * h} : XRange{1, 0};
    }
};

/// Per odd-axis mask: the coarse neighbours (±h on every odd axis) and the
/// fine ones (±h on one even axis) of the neighbour predictor, as 27-indices.
struct PredictorStencils {
    uint8_t nc[8]{}, nf[8]{};
    uint8_t coarse[8][8]{}, fine[8][6]{};
    PredictorStencils() {
        for (int mask = 1; mask < 8; ++mask) {
            for (int s = 0; s < 8; ++s) {
                int o[3];
                bool ok = true;
                for (int a = 0; a < 3; ++a) {
                    const int bit = (s >> a) & 1;
                    if (mask & (1 << a)) o[a] = bit ? 1 : -1;
                    else if (bit) ok = false;
                    else o[a] = 0;
                }
                if (ok) coarse[mask][nc[mask]++] = uint8_t(nb27(o[0], o[1], o[2]));
            }
            for (int a = 0; a < 3; ++a) {
                if (mask & (1 << a)) continue;
                for (int sg = -1; sg <= 1; sg += 2) {
                    int o[3] = {0, 0, 0};
                    o[a] = sg;
                    fine[mask][nf[mask]++] = uint8_t(nb27(o[0], o[1], o[2]));
                }
            }
        }
    }
};
inline const PredictorStencils& predictor_stencils() {
    static const PredictorStencils table;
    return table;
}

/// Asks for the cache line holding p.
inline void prefetch_line(const void* p) {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    // GCC deletes loops whose only effect is __builtin_prefetch (C++ loops
    // without side effects may be assumed to end, then dropped): asm it is.
    asm volatile("prefetcht0 %0" : : "m"(*static_cast<const char*>(p)));
#else
    __builtin_prefetch(p);
#endif
}

/// Asks for the cache lines of a chunk's lattice points (its box grown by
/// `grow` steps of 2^t, clipped to B) before a coder walks them. The coders pass
/// over the box once per class in rows of a few points that lie planes apart;
/// without this the first line of each row is a miss that the range coder's
/// serial work cannot overlap, and it was most of the error coder's time.
template <class V>
void prefetch_chunk(const Geometry& G, const V* data, int t, const std::array<int64_t, 6>& b, int64_t grow) {
    const int64_t h = int64_t{1} << t;
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = std::max<int64_t>(0, (b[a] + h - 1) / h * h - grow * h);
        hi[a] = std::min<int64_t>(G.box_max[a], b[3 + a] + grow * h) / h * h;
        if (lo[a] > hi[a]) return;
    }
    // Bytes between lattice neighbours along x in the array (G may hold
    // every grid point, or only those of the lattice).
    const int64_t stride = (h >> std::min(G.shift, t)) * int64_t(sizeof(V));
    const int64_t step = std::max<int64_t>(64, stride);
    for (int64_t z = lo[2]; z <= hi[2]; z += h)
        for (int64_t y = lo[1]; y <= hi[1]; y += h) {
            const char* first = reinterpret_cast<const char*>(data + G.index(lo[0], y, z));
            const char* last = reinterpret_cast<const char*>(data + G.index(hi[0], y, z));
            for (const char* p = first; p < last; p += step) prefetch_line(p);
            prefetch_line(last);
        }
}

struct Prediction {
    int64_t p = 0;
    uint64_t spread = 0;
};

/// Spec §7.3 (Predictor = 2).
template <class T>
Prediction predict_v2(const Geometry& G, const T* v, int t, int cls, int64_t x, int64_t y, int64_t z,
                      const std::array<int64_t, 6>& cb) {
    Prediction r;
    if (cls == 3) return r;
    const int64_t h = int64_t{1} << t;
    const int64_t c[3] = {x, y, z};
    int64_t mn = std::numeric_limits<int64_t>::max(), mx = std::numeric_limits<int64_t>::min();
    auto val = [&](int64_t a, int64_t b2, int64_t d) {
        const int64_t w = Dom<T>::get(v[G.index(a, b2, d)]);
        mn = std::min(mn, w);
        mx = std::max(mx, w);
        return w;
    };
    auto in_chunk = [&](const int64_t q[3]) {
        for (int a = 0; a < 3; ++a)
            if (q[a] < cb[a] || q[a] > cb[3 + a]) return false;
        return true;
    };
    // Coarse neighbours (as predictor 1).
    int64_t lo[3], hi[3];
    int shift = 0;
    bool all_in = true;
    for (int a = 0; a < 3; ++a) {
        if ((c[a] & h) != 0) {
            lo[a] = c[a] - h;
            if (c[a] + h <= G.box_max[a]) {
                hi[a] = c[a] + h;
                ++shift;
            } else {
                hi[a] = lo[a];
                all_in = false;
            }
        } else {
            lo[a] = hi[a] = c[a];
        }
    }
    i128 coarse = 0;
    for (int64_t zz = lo[2];; zz = hi[2]) {
        for (int64_t yy = lo[1];; yy = hi[1]) {
            coarse += val(lo[0], yy, zz);
            if (hi[0] != lo[0]) coarse += val(hi[0], yy, zz);
            if (yy == hi[1]) break;
        }
        if (zz == hi[2]) break;
    }
    // Same-cycle neighbours at distance h along the even axes, when all are in the chunk.
    i128 fine = 0;
    bool fine_ok = all_in && cls > 0 ;
    for (int a = 0; a < 3 && fine_ok; ++a) {
        if ((c[a] & h) != 0) continue;
        for (int s = -1; s <= 1; s += 2) {
            int64_t q[3] = {c[0], c[1], c[2]};
            q[a] += s * h;
            if (!in_chunk(q)) {
                fine_ok = false;
                break;
            }
        }
    }
    if (fine_ok) {
        for (int a = 0; a < 3; ++a) {
            if ((c[a] & h) != 0) continue;
            for (int s = -1; s <= 1; s += 2) {
                int64_t q[3] = {c[0], c[1], c[2]};
                q[a] += s * h;
                fine += val(q[0], q[1], q[2]);
            }
        }
        if (cls == 1)  // 4 face corners + 2 cube centres: (sum4 + 2 sum2) / 8
            r.p = int64_t((coarse + 2 * fine) >> 3);
        else  // edge: 2 ends + 4 face centres: (2 (A + B) + sum4) / 8
            r.p = int64_t((2 * coarse + fine) >> 3);
    } else {
        r.p = int64_t(coarse >> shift);
    }
    r.spread = uint64_t(mx) - uint64_t(mn);
    return r;
}

}  // namespace tetlod::ht_detail
