#pragma once
// The coding order 2 of a chunk (spec §7.4) as rows: per class pass, per (z, y),
// the points of one class along x. The field coders work a row at a time so
// that what is the same along a row (the class, the odd-axis mask, whether y
// and z are inside the chunk, the predictor's stencil offsets) is worked out
// once per row instead of once per point; per point the interior fast path is
// then a few loads and adds (profile of bucky 128^3: the per-point stencil
// lookups, interior test and slot arithmetic were a third of the decode).

#include "ht_prediction.hpp"

namespace tetlod::ht_detail {

/// Points (x0 + i·step, y, z), x <= x1, all of class `cls` (3: corners).
struct ChunkRow {
    int cls = 0;
    int64_t y = 0, z = 0, x0 = 0, x1 = 0, step = 1;
};

/// Lattice strides (LatticeView: x 1, y px, z pxy) of the even axes of a row
/// of class 0..2, for LatticeView::neighbour_mean_in_order: class 1 has one
/// (even1), class 2 two (even1, even2), class 0 none (both stay 0).
struct RowEvenStrides {
    int64_t even1 = 0, even2 = 0;
};
inline RowEvenStrides row_even_strides(const ChunkRow& r, const LatticeView& lat) {
    const int64_t h = r.step / 2;  // rows of classes 0..2 step by 2h (for_each_row_v2)
    const bool odd[3] = {(r.x0 & h) != 0, (r.y & h) != 0, (r.z & h) != 0};
    const int64_t stride[3] = {1, lat.px, lat.pxy};
    RowEvenStrides e;
    int found = 0;
    for (int a = 0; a < 3; ++a)
        if (!odd[a]) (found++ == 0 ? e.even1 : e.even2) = stride[a];
    return e;
}

/// Calls f(row) for the chunk's rows in coding order 2 (the order of
/// for_each_point_v2, which is defined through this walker).
template <class F>
void for_each_row_v2(const Geometry& G, int t, const std::array<int64_t, 6>& b, F&& f) {
    const int64_t h = int64_t{1} << t;
    if (t == G.k) {  // cube corners: one pass, spacing L = h
        auto up = [&](int64_t v) { return (v + h - 1) / h * h; };
        for (int64_t z = up(b[2]); z <= b[5]; z += h)
            for (int64_t y = up(b[1]); y <= b[4]; y += h) {
                const int64_t x0 = up(b[0]);
                if (x0 <= b[3]) f(ChunkRow{3, y, z, x0, b[3], h});
            }
        return;
    }
    auto up = [&](int64_t v) { return (v + h - 1) / h * h; };
    for (int cls = 0; cls < 3; ++cls) {
        const int want_odd = 3 - cls;
        for (int64_t z = up(b[2]); z <= b[5]; z += h) {
            const int oz = (z & h) != 0;
            for (int64_t y = up(b[1]); y <= b[4]; y += h) {
                const int oy = (y & h) != 0;
                // x parity fixed by the class: odd needed iff want_odd - oz - oy == 1.
                const int need = want_odd - oz - oy;
                if (need < 0 || need > 1) continue;
                int64_t x = up(b[0]);
                if (((x & h) != 0) != (need == 1)) x += h;
                if (x <= b[3]) f(ChunkRow{cls, y, z, x, b[3], 2 * h});
            }
        }
    }
}

/// Calls f(x, y, z, cls) for the chunk's points in coding order 2: class 0
/// (cube centres), class 1 (face centres), class 2 (edge midpoints), each z
/// outer, x inner; the corner cycle t = k is one pass with cls = 3.
template <class F>
void for_each_point_v2(const Geometry& G, int t, const std::array<int64_t, 6>& b, F&& f) {
    for_each_row_v2(G, t, b, [&](const ChunkRow& r) {
        for (int64_t x = r.x0; x <= r.x1; x += r.step) f(x, r.y, r.z, r.cls);
    });
}

/// Number of coarse and fine stencil points of the neighbour predictor for a
/// point of class cls inside its chunk (spec §7.4: 8 cube corners; 4 face
/// corners + 2 cube centres; 2 edge ends + 4 face centres).
template <int Cls> constexpr int kCoarseCount = Cls == 0 ? 8 : (Cls == 1 ? 4 : 2);
template <int Cls> constexpr int kFineCount = Cls == 0 ? 0 : (Cls == 1 ? 2 : 4);

/// The neighbour predictor along one row. Spec §7.4 reads the coarse stencil
/// whenever it lies in B and adds the fine one when that lies in the chunk's
/// box too; both tests split into a per-row part (y, z) and an x range, so a
/// point needs the general predict_v2 only when a coarse neighbour is outside
/// B (the far faces of B). Points on the chunk's faces (about a fifth of a
/// 32^3 brick) then take the fixed stencil as well. Same result as
/// predict_v2 everywhere.
template <class T, int Cls>
struct RowPredictor {
    int64_t off[8]{};           // coarse offsets, then fine ones (linear field offsets)
    int64_t coarse_hi = -1;     // coarse stencil in B iff x <= coarse_hi
    int64_t fine_lo = 0, fine_hi = -1;  // fine stencil in the chunk iff fine_lo <= x <= fine_hi

    RowPredictor(const Geometry& G, const ChunkFrame& F, const ChunkRow& r) {
        static_assert(Cls >= 0 && Cls < 3, "corners (class 3) are predicted as 0, without a stencil");
        const int64_t h = F.h;
        // Along a row y and z are fixed and x keeps its parity (step 2h), so the
        // odd-axis mask is the row's.
        const int mask = ((r.x0 & h) ? 1 : 0) | ((r.y & h) ? 2 : 0) | ((r.z & h) ? 4 : 0);
        // Coarse neighbours: c ± h on the odd axes; c - h >= 0 always holds.
        const bool yz_coarse = (!(mask & 2) || r.y + h <= G.box_max[1]) && (!(mask & 4) || r.z + h <= G.box_max[2]);
        coarse_hi = !yz_coarse ? std::numeric_limits<int64_t>::min()
                    : (mask & 1) ? G.box_max[0] - h
                                 : std::numeric_limits<int64_t>::max();
        // Fine neighbours: c ± h on the even axes, inside the chunk's box.
        const bool yz_fine = ((mask & 2) || (r.y - h >= F.cb[1] && r.y + h <= F.cb[4])) &&
                             ((mask & 4) || (r.z - h >= F.cb[2] && r.z + h <= F.cb[5]));
        if (yz_fine) {
            fine_lo = (mask & 1) ? std::numeric_limits<int64_t>::min() : F.cb[0] + h;
            fine_hi = (mask & 1) ? std::numeric_limits<int64_t>::max() : F.cb[3] - h;
        } else {
            fine_lo = std::numeric_limits<int64_t>::max();
            fine_hi = std::numeric_limits<int64_t>::min();
        }
        const PredictorStencils& P = predictor_stencils();
        for (int i = 0; i < kCoarseCount<Cls>; ++i) off[i] = F.off[P.coarse[mask][i]];
        for (int i = 0; i < kFineCount<Cls>; ++i) off[kCoarseCount<Cls> + i] = F.off[P.fine[mask][i]];
    }
    /// Whether at() applies to the point of the row at x.
    bool fixed(int64_t x) const { return x <= coarse_hi; }

    /// Spec §7.4 for a point whose coarse stencil is in B (fixed(x); idx: its field index).
    Prediction at(const T* v, int64_t idx, int64_t x) const {
        using Sum = std::conditional_t<(sizeof(T) < 8), int64_t, i128>;
        const T* c = v + idx;
        int64_t w = Dom<T>::get(c[off[0]]);
        int64_t mn = w, mx = w;
        Sum coarse = w;
        for (int i = 1; i < kCoarseCount<Cls>; ++i) {
            w = Dom<T>::get(c[off[i]]);
            coarse += w;
            mn = std::min(mn, w);
            mx = std::max(mx, w);
        }
        Prediction r;
        // log2 of the coarse count: the coarse mean's shift.
        constexpr int kShift = Cls == 0 ? 3 : (Cls == 1 ? 2 : 1);
        if constexpr (Cls == 0) {
            r.p = int64_t(coarse >> kShift);
        } else {
            if (x >= fine_lo && x <= fine_hi) {
                Sum fine = 0;
                for (int i = 0; i < kFineCount<Cls>; ++i) {
                    w = Dom<T>::get(c[off[kCoarseCount<Cls> + i]]);
                    fine += w;
                    mn = std::min(mn, w);
                    mx = std::max(mx, w);
                }
                r.p = Cls == 1 ? int64_t((coarse + 2 * fine) >> 3) : int64_t((2 * coarse + fine) >> 3);
            } else {
                r.p = int64_t(coarse >> kShift);
            }
        }
        r.spread = uint64_t(mx) - uint64_t(mn);
        return r;
    }
};

/// Calls f.template operator()<Cls>(row) (a lambda `[&]<int Cls>(const ChunkRow&)`)
/// with the row's class as a template argument, so per-class loops get fixed
/// stencil sizes.
template <class F>
void dispatch_row_class(const ChunkRow& r, F&& f) {
    switch (r.cls) {
        case 0: f.template operator()<0>(r); break;
        case 1: f.template operator()<1>(r); break;
        case 2: f.template operator()<2>(r); break;
        default: f.template operator()<3>(r); break;
    }
}

}  // namespace tetlod::ht_detail
