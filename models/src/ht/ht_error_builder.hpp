#pragma once
// Evaluators of exact per-diamond errors (spec/tlod-format.md §2 "Diamond error"; docs/ht.md "Errors").
//
// Each level of the HT tiles the cube, so one level costs about one visit per
// grid point. Two evaluators, chosen per diamond:
//  - diamonds fully inside the data box use a template precomputed per level
//    and shape: for the smallest (h <= 4) the grid points of the diamond with
//    their integer barycentric weights, as linear-index offsets (no per-row
//    set-up, which would dominate when a tet holds a handful of points); up to
//    h = 16 the row spans of each tet with the barycentric numerators at each
//    row's start (no divisions);
//  - larger or boundary diamonds scan each tet row by row: the integer
//    barycentric numerators D_i are affine along a row, so the x range inside the
//    closed tet follows from four divisions, and the interpolant from adds.
//    For exact integer evaluation, boundary diamonds of templated levels take
//    their tets inside the data box from the level's span rows instead
//    (boundary_error: the same errors, without the per-row divisions).
// Errors are compared as |f*D - sum D_i f_i| / D with |D| a power of two: exact
// for integer data (double or 128-bit accumulators, see compute_diamond_errors).
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <cmath>
#include <type_traits>
#include <limits>
#include <map>
#include <unordered_map>

#include "tetlod/models/detail/ht_geometry.hpp"
#include "tet_box.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::ht::error_detail {

constexpr int32_t kTemplateMaxH = 16;      // span templates up to here
constexpr int32_t kPointTemplateMaxH = 4;  // point templates up to here (measured best)

inline int64_t floor_div(int64_t a, int64_t b) {  // b > 0
    int64_t q = a / b;
    if ((a % b != 0) && (a < 0)) --q;
    return q;
}
inline int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

/// Barycentric numerators D_i(p) = n_i . p + c_i of a positively oriented tet.
struct Barycentric {
    int64_t n[4][3];
    int64_t c[4];
    int64_t D;
};

template <class V>
Barycentric barycentric_of(Tet t, V* f) {
    Barycentric b;
    int64_t D = orient(t[0], t[1], t[2], t[3]);
    if (D < 0) {
        std::swap(t[2], t[3]);
        std::swap(f[2], f[3]);
        D = -D;
    }
    b.D = D;
    const int64_t e[3][3] = {{t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]},
                             {t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]},
                             {t[3][0] - t[0][0], t[3][1] - t[0][1], t[3][2] - t[0][2]}};
    auto cross = [](const int64_t* u, const int64_t* v, int64_t* out) {
        out[0] = u[1] * v[2] - u[2] * v[1];
        out[1] = u[2] * v[0] - u[0] * v[2];
        out[2] = u[0] * v[1] - u[1] * v[0];
    };
    // D1 = q.(e2 x e3), D2 = q.(e3 x e1), D3 = q.(e1 x e2), q = p - v0
    cross(e[1], e[2], b.n[1]);
    cross(e[2], e[0], b.n[2]);
    cross(e[0], e[1], b.n[3]);
    int64_t csum = 0;
    for (int i = 1; i < 4; ++i) {
        b.c[i] = -(b.n[i][0] * t[0][0] + b.n[i][1] * t[0][1] + b.n[i][2] * t[0][2]);
        csum += b.c[i];
    }
    for (int a = 0; a < 3; ++a) b.n[0][a] = -(b.n[1][a] + b.n[2][a] + b.n[3][a]);
    b.c[0] = D - csum;
    return b;
}

/// Accumulators: double where every term is exact (|values| * |D| < 2^49), else
/// 128-bit integers (32-bit integer data, very deep hierarchies).
template <class Acc>
Acc abs_value(Acc v) {
    if constexpr (std::is_same_v<Acc, double>) return std::abs(v);  // branch-free
    else return v < 0 ? -v : v;
}

/// Converts a non-negative accumulator to double, rounding up.
template <class Acc>
double to_double_up(Acc v) {
    if constexpr (std::is_same_v<Acc, double>) {
        return v;
    } else {
        double d = double(v);
        if (Acc(d) < v) d = std::nextafter(d, std::numeric_limits<double>::infinity());
        return d;
    }
}

/// Reorders t to positive orientation (as barycentric_of does) and returns its
/// barycentric numerators, for templates that keep the vertex order.
inline Barycentric orient_positive(Tet& t) {
    double unused[4] = {0, 0, 0, 0};
    const Barycentric b = barycentric_of(t, unused);
    if (orient(t[0], t[1], t[2], t[3]) < 0) std::swap(t[2], t[3]);
    return b;
}

/// x / D for the |D| of a tet, which is a power of two: a multiplication by the
/// exact inverse, which is the same double and spares a division's latency
/// per diamond (a division otherwise, should D ever not be one).
struct DivideByD {
    double D = 1, inverse = 1;
    bool power_of_two = true;
    explicit DivideByD(double d = 1) : D(d), inverse(1.0 / d), power_of_two(std::has_single_bit(uint64_t(d))) {}
    double operator()(double x) const { return power_of_two ? x * inverse : x / D; }
};

template <class T, class Acc>
class ErrorBuilder {
public:
    /// `window` holds the field on the planes z0, z0 + 1, ... of B (x fastest,
    /// rows of X values, planes of XY): the whole field (z0 = 0) or a slab.
    ErrorBuilder(const T* window, int64_t z0, int64_t X, int64_t XY, const HtDomain& dom)
        : f_(window), dom_(dom), z0_(z0), X_(X), XY_(XY) {}

    int64_t index(const Pt& p) const { return (p[2] - z0_) * XY_ + p[1] * X_ + p[0]; }

    /// max |f*D - N| over the closed tet's points, divided by D: scans rows.
    double scan_tet(const Tet& t) const {
        Acc fv[4];
        for (int i = 0; i < 4; ++i) fv[i] = Acc(f_[index(t[i])]);
        int64_t D = 1;
        const Acc worst = scan_rows(t, fv, std::numeric_limits<int64_t>::min(),
                                    std::numeric_limits<int64_t>::max(), D);
        return to_double_up(worst) / double(D);
    }

    /// max |f*D - N| over the closed tet's points in planes zlo..zhi (which the
    /// window must hold), undivided; `fv` the values at t's vertices (they may
    /// lie outside the window); D receives the tet's |D|. The same arithmetic
    /// row by row as a whole-tet scan, so maxima over slabs combine exactly.
    Acc scan_rows(Tet t, Acc fv[4], int64_t zlo, int64_t zhi, int64_t& Dout) const {
        Barycentric b = barycentric_of(t, fv);
        Dout = b.D;
        int32_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min({t[0][a], t[1][a], t[2][a], t[3][a]});
            hi[a] = std::max({t[0][a], t[1][a], t[2][a], t[3][a]});
        }
        const Acc D = Acc(b.D);
        Acc A = 0;  // slope of N along x
        for (int i = 0; i < 4; ++i) A += Acc(b.n[i][0]) * fv[i];
        Acc worst = 0;
        for (int64_t z = std::max<int64_t>(lo[2], zlo); z <= std::min<int64_t>(hi[2], zhi); ++z) {
            for (int64_t y = lo[1]; y <= hi[1]; ++y) {
                int64_t x0 = lo[0], x1 = hi[0];
                Acc Bc = 0;
                for (int i = 0; i < 4 && x0 <= x1; ++i) {
                    const int64_t bi = b.n[i][1] * y + b.n[i][2] * z + b.c[i];
                    const int64_t ai = b.n[i][0];
                    Bc += Acc(bi) * fv[i];
                    if (ai > 0) x0 = std::max(x0, ceil_div(-bi, ai));
                    else if (ai < 0) x1 = std::min(x1, floor_div(bi, -ai));
                    else if (bi < 0) x1 = x0 - 1;
                }
                if (x0 > x1) continue;
                const T* row = f_ + (z - z0_) * XY_ + y * X_;
                if (y + kRowsAhead <= hi[1]) {
                    __builtin_prefetch(row + kRowsAhead * X_ + x0);
                    __builtin_prefetch(row + kRowsAhead * X_ + x1);
                }
                if constexpr (kExactInt) {
                    const int64_t e = row_max_exact(row, x0, x1, int64_t(b.D), int64_t(A), int64_t(Bc));
                    worst = Acc(e) > worst ? Acc(e) : worst;
                } else {
                    for (int64_t x = x0; x <= x1; ++x) {
                        const Acc e = abs_value(Acc(row[x]) * D - (A * Acc(x) + Bc));
                        worst = e > worst ? e : worst;
                    }
                }
            }
        }
        return worst;
    }

    /// Integer data whose terms stay below 2^53 (the double accumulator is then
    /// exact): the same values in 64-bit integers, without conversions, and with
    /// two independent maxima so the loop is not bound by the max's latency.
    static constexpr bool kExactInt = std::is_integral_v<T> && std::is_same_v<Acc, double>;

    /// Row scans prefetch the row this many rows ahead: a row holds about 20
    /// points, too few to hide the miss on its first line.
    static constexpr int64_t kRowsAhead = 4;

    /// max over x in x0..x1 of |row[x] * D - (A x + B)| (exact integers).
    static int64_t row_max_exact(const T* row, int64_t x0, int64_t x1, int64_t D, int64_t A, int64_t B) {
        int64_t n0 = A * x0 + B, n1 = n0 + A;
        const int64_t A2 = 2 * A;
        int64_t w0 = 0, w1 = 0;
        int64_t x = x0;
        for (; x + 1 <= x1; x += 2, n0 += A2, n1 += A2) {
            const int64_t e0 = int64_t(row[x]) * D - n0, e1 = int64_t(row[x + 1]) * D - n1;
            w0 = std::max(w0, e0 < 0 ? -e0 : e0);
            w1 = std::max(w1, e1 < 0 ? -e1 : e1);
        }
        if (x <= x1) {
            const int64_t e0 = int64_t(row[x]) * D - n0;
            w0 = std::max(w0, e0 < 0 ? -e0 : e0);
        }
        return std::max(w0, w1);
    }

    /// Template: the non-vertex grid points of one diamond shape, each with the
    /// offsets and integer weights of the tet vertices interpolating it.
    struct Template {
        struct Entry {
            int64_t p;
            int64_t v[4];
            Acc w[4];
        };
        std::vector<Entry> entries;
        Acc D = 1;
        DivideByD divide;
        /// kExactInt: the same entries with their nonzero weights only, grouped
        /// by how many there are (2: on an edge, 3: in a face, 4: inside), as
        /// flat rows {p, v_1, w_1, ..., v_n, w_n}.
        std::array<std::vector<int64_t>, 5> exact;
    };

    Template make_template(const Pt& c, const DiamondInfo& d) const {
        Template tpl;
        Tet tets[8];
        // a representative centre of the same shape far from the cube's faces
        const int n = diamond_tets(c, d, dom_.L, tets);
        std::map<int64_t, typename Template::Entry> points;
        for (int ti = 0; ti < n; ++ti) {
            Tet t = tets[ti];
            const Barycentric b = orient_positive(t);
            tpl.D = Acc(b.D);
            for (int32_t z = c[2] - d.h; z <= c[2] + d.h; ++z)
                for (int32_t y = c[1] - d.h; y <= c[1] + d.h; ++y)
                    for (int32_t x = c[0] - d.h; x <= c[0] + d.h; ++x) {
                        int64_t w[4];
                        bool in = true, vertex = false;
                        for (int i = 0; i < 4; ++i) {
                            w[i] = b.n[i][0] * x + b.n[i][1] * y + b.n[i][2] * z + b.c[i];
                            if (w[i] < 0) in = false;
                            if (w[i] == b.D) vertex = true;
                        }
                        if (!in || vertex) continue;
                        const Pt p{x, y, z};
                        const int64_t off = index(p) - index(c);
                        typename Template::Entry e;
                        e.p = off;
                        for (int i = 0; i < 4; ++i) {
                            e.v[i] = index(t[i]) - index(c);
                            e.w[i] = Acc(w[i]);
                        }
                        points.emplace(off, e);  // shared-face points: same value either way
                    }
        }
        tpl.divide = DivideByD(double(tpl.D));
        for (auto& [off, e] : points) tpl.entries.push_back(e);
        if constexpr (kExactInt) {
            for (const auto& e : tpl.entries) {
                int n = 0;
                for (int i = 0; i < 4; ++i) n += e.w[i] != 0;
                auto& rows = tpl.exact[std::size_t(n)];
                rows.push_back(e.p);
                for (int i = 0; i < 4; ++i)
                    if (e.w[i] != 0) {
                        rows.push_back(e.v[i]);
                        rows.push_back(int64_t(e.w[i]));
                    }
            }
        }
        return tpl;
    }

    double eval_template(const Template& tpl, int64_t ci) const {
        const T* base = f_ + ci;
        if constexpr (kExactInt) return tpl.divide(double(eval_exact(tpl, base)));
        Acc worst = 0;
        for (const auto& e : tpl.entries) {
            const Acc n = e.w[0] * Acc(base[e.v[0]]) + e.w[1] * Acc(base[e.v[1]]) +
                          e.w[2] * Acc(base[e.v[2]]) + e.w[3] * Acc(base[e.v[3]]);
            const Acc err = abs_value(Acc(base[e.p]) * tpl.D - n);
            worst = err > worst ? err : worst;
        }
        return tpl.divide(to_double_up(worst));
    }

    /// max |f(p) D - sum w_i f(v_i)| over a point template's entries, in exact
    /// integers (kExactInt): the nonzero weights only, two maxima in flight.
    static int64_t eval_exact(const Template& tpl, const T* base) {
        const int64_t D = int64_t(tpl.D);
        int64_t w[2] = {0, 0};
        eval_exact_group<1>(tpl.exact[1], base, D, w);
        eval_exact_group<2>(tpl.exact[2], base, D, w);
        eval_exact_group<3>(tpl.exact[3], base, D, w);
        eval_exact_group<4>(tpl.exact[4], base, D, w);
        return std::max(w[0], w[1]);
    }

    /// The rows of one weight count N: a compile-time N unrolls each row's sum.
    template <int N>
    static void eval_exact_group(const std::vector<int64_t>& rows, const T* base, int64_t D, int64_t w[2]) {
        constexpr std::size_t kStride = 1 + 2 * N;
        const std::size_t count = rows.size() / kStride;
        const int64_t* r = rows.data();
        auto error = [base, D](const int64_t* a) {
            int64_t s = 0;
            for (int i = 0; i < N; ++i) s += a[2 + 2 * i] * int64_t(base[a[1 + 2 * i]]);
            const int64_t e = int64_t(base[a[0]]) * D - s;
            return e < 0 ? -e : e;
        };
        int64_t w0 = w[0], w1 = w[1];
        std::size_t i = 0;
        for (; i + 1 < count; i += 2) {
            w0 = std::max(w0, error(r + i * kStride));
            w1 = std::max(w1, error(r + (i + 1) * kStride));
        }
        if (i < count) w0 = std::max(w0, error(r + i * kStride));
        w[0] = w0;
        w[1] = w1;
    }

    /// eval_exact for two centres of one template (at b0 and b1): each template
    /// row is read once for both, and the two sums are independent work.
    static void eval_exact_pair(const Template& tpl, const T* b0, const T* b1, int64_t out[2]) {
        const int64_t D = int64_t(tpl.D);
        int64_t w0 = 0, w1 = 0;
        eval_exact_pair_group<1>(tpl.exact[1], b0, b1, D, w0, w1);
        eval_exact_pair_group<2>(tpl.exact[2], b0, b1, D, w0, w1);
        eval_exact_pair_group<3>(tpl.exact[3], b0, b1, D, w0, w1);
        eval_exact_pair_group<4>(tpl.exact[4], b0, b1, D, w0, w1);
        out[0] = w0;
        out[1] = w1;
    }

    template <int N>
    static void eval_exact_pair_group(const std::vector<int64_t>& rows, const T* b0, const T* b1, int64_t D,
                                      int64_t& w0, int64_t& w1) {
        constexpr std::size_t kStride = 1 + 2 * N;
        const std::size_t count = rows.size() / kStride;
        const int64_t* r = rows.data();
        for (std::size_t i = 0; i < count; ++i, r += kStride) {
            int64_t s0 = 0, s1 = 0;
            for (int k = 0; k < N; ++k) {
                const int64_t off = r[1 + 2 * k], wt = r[2 + 2 * k];
                s0 += wt * int64_t(b0[off]);
                s1 += wt * int64_t(b1[off]);
            }
            const int64_t e0 = int64_t(b0[r[0]]) * D - s0, e1 = int64_t(b1[r[0]]) * D - s1;
            w0 = std::max(w0, e0 < 0 ? -e0 : e0);
            w1 = std::max(w1, e1 < 0 ? -e1 : e1);
        }
    }

    /// Span template: per tet of one diamond shape, the row spans of its grid
    /// points with the barycentric numerators at each row's x = 0 (relative to the
    /// centre). Evaluation then costs a few multiply-adds per row and one
    /// multiply-subtract per point, with no divisions.
    struct SpanTemplate {
        struct Span {
            int64_t row;     // linear offset of (c.x, y, z) from the centre
            int32_t x0, x1;  // x range relative to the centre, inclusive
            int64_t b[4];    // D_i at relative x = 0
        };
        struct TetSpans {
            Pt rel[4];     // the vertices minus the centre, in diamond_tets' order (before orienting)
            int64_t v[4];  // vertex offsets from the centre
            int64_t a[4];  // d D_i / dx
            std::size_t first = 0, count = 0;
        };
        std::vector<TetSpans> tets;
        std::vector<Span> spans;
        Acc D = 1;
        DivideByD divide;
    };

    SpanTemplate make_span_template(const Pt& c, const DiamondInfo& d) const {
        SpanTemplate st;
        Tet tets[8];
        const int n = diamond_tets(c, d, dom_.L, tets);
        for (int ti = 0; ti < n; ++ti) {
            Tet t = tets[ti];
            typename SpanTemplate::TetSpans ts;
            for (int i = 0; i < 4; ++i)
                for (int a = 0; a < 3; ++a) ts.rel[i][a] = t[i][a] - c[a];
            const Barycentric b = orient_positive(t);
            st.D = Acc(b.D);
            for (int i = 0; i < 4; ++i) {
                ts.v[i] = index(t[i]) - index(c);
                ts.a[i] = b.n[i][0];
            }
            ts.first = st.spans.size();
            int32_t lo[3], hi[3];
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min({t[0][a], t[1][a], t[2][a], t[3][a]});
                hi[a] = std::max({t[0][a], t[1][a], t[2][a], t[3][a]});
            }
            for (int64_t z = lo[2]; z <= hi[2]; ++z)
                for (int64_t y = lo[1]; y <= hi[1]; ++y) {
                    int64_t x0 = lo[0], x1 = hi[0];
                    typename SpanTemplate::Span sp;
                    for (int i = 0; i < 4; ++i) {
                        const int64_t bi = b.n[i][1] * y + b.n[i][2] * z + b.c[i];
                        const int64_t ai = b.n[i][0];
                        sp.b[i] = ai * c[0] + bi;
                        if (ai > 0) x0 = std::max(x0, ceil_div(-bi, ai));
                        else if (ai < 0) x1 = std::min(x1, floor_div(bi, -ai));
                        else if (bi < 0) x1 = x0 - 1;
                    }
                    if (x0 > x1) continue;
                    sp.row = (z - c[2]) * XY_ + (y - c[1]) * X_;
                    sp.x0 = int32_t(x0 - c[0]);
                    sp.x1 = int32_t(x1 - c[0]);
                    st.spans.push_back(sp);
                }
            ts.count = st.spans.size() - ts.first;
            st.tets.push_back(ts);
        }
        st.divide = DivideByD(double(st.D));
        return st;
    }

    double eval_span_template(const SpanTemplate& st, int64_t ci) const {
        const T* base = f_ + ci;
        Acc worst = 0;
        for (const auto& ts : st.tets) {
            const Acc e = span_tet_max(st, ts, base);
            worst = e > worst ? e : worst;
        }
        return st.divide(to_double_up(worst));
    }

    /// max |f D - N| over the points of one tet of a span template (undivided).
    Acc span_tet_max(const SpanTemplate& st, const typename SpanTemplate::TetSpans& ts, const T* base) const {
        const Acc D = st.D;
        Acc worst = 0;
        Acc fv[4], A = 0;
        for (int i = 0; i < 4; ++i) {
            fv[i] = Acc(base[ts.v[i]]);
            A += Acc(ts.a[i]) * fv[i];
        }
        const auto* sp = st.spans.data() + ts.first;
        for (std::size_t k = 0; k < ts.count; ++k, ++sp) {
            // The rows of a diamond are up to 2h planes apart: ask for a
            // later row's first line now (the scan of one row is too short
            // to hide a miss).
            if (k + kRowsAhead < ts.count) __builtin_prefetch(base + sp[kRowsAhead].row + sp[kRowsAhead].x0);
            const Acc Bc = Acc(sp->b[0]) * fv[0] + Acc(sp->b[1]) * fv[1] +
                           Acc(sp->b[2]) * fv[2] + Acc(sp->b[3]) * fv[3];
            const T* row = base + sp->row;
            if constexpr (kExactInt) {
                const Acc e = Acc(row_max_exact(row, sp->x0, sp->x1, int64_t(D), int64_t(A), int64_t(Bc)));
                worst = e > worst ? e : worst;
                continue;
            }
            for (int32_t x = sp->x0; x <= sp->x1; ++x) {
                const Acc e = abs_value(Acc(row[x]) * D - (A * Acc(x) + Bc));
                worst = e > worst ? e : worst;
            }
        }
        return worst;
    }

    /// diamond_error for a centre near the data box's faces, from the level's
    /// span template: its tets inside B are scanned along the template's rows
    /// (no per-row divisions), those crossing B make it infinite, those
    /// outside are skipped, as diamond_error does. Exact integers only
    /// (kExactInt): each tet's maximum is then the same integer whichever way
    /// its points are visited, and all tets of a level share |D|, a power of
    /// two, so max_i (w_i / D) = (max_i w_i) / D. These diamonds, a few percent
    /// of the finest levels, took ~15% of an encode through scan_rows.
    double boundary_error(const SpanTemplate& st, const Pt& c) const {
        const DiamondInfo d = classify_centre(c, dom_.k);
        Tet tets[8];
        const int n = diamond_tets(c, d, dom_.L, tets);
        const T* base = f_ + index(c);
        Acc worst = 0;
        std::size_t j = 0;  // the cube clips tets from the list, never reorders it
        for (int i = 0; i < n; ++i) {
            Pt rel[4];
            for (int v = 0; v < 4; ++v)
                for (int a = 0; a < 3; ++a) rel[v][a] = tets[i][v][a] - c[a];
            while (j < st.tets.size() && !std::equal(rel, rel + 4, st.tets[j].rel)) ++j;
            if (j == st.tets.size()) return diamond_error(c, d);  // not the template's shape (never expected)
            switch (classify_against_data_box(tets[i], dom_.box_max)) {
                case BoxRelation::Outside: break;
                case BoxRelation::Crossing: return std::numeric_limits<double>::infinity();
                case BoxRelation::Inside: {
                    const Acc e = span_tet_max(st, st.tets[j], base);
                    worst = e > worst ? e : worst;
                    break;
                }
            }
        }
        return st.divide(to_double_up(worst));
    }

    double diamond_error(const Pt& c, const DiamondInfo& d) const {
        Tet tets[8];
        const int n = diamond_tets(c, d, dom_.L, tets);
        double err = 0;
        for (int i = 0; i < n; ++i) {
            switch (classify_against_data_box(tets[i], dom_.box_max)) {
                case BoxRelation::Outside: break;
                case BoxRelation::Crossing: return std::numeric_limits<double>::infinity();
                case BoxRelation::Inside: err = std::max(err, scan_tet(tets[i])); break;
            }
        }
        return err;
    }

    /// The templates of one level: indexed by the centre's residues mod 4h
    /// (they fix the spine directions), built on a representative centre well
    /// inside the cube. Only offsets are taken from it, never values.
    struct LevelTemplates {
        int level = 0;
        int log2h = 0;
        bool use = false, point = false;
        std::vector<Template> point_templates;
        std::vector<SpanTemplate> span_templates;
        /// kExactInt, point levels: span templates too, for boundary_error
        /// (a point template merges its tets' points; the boundary needs them apart).
        std::vector<SpanTemplate> boundary_templates;
        const SpanTemplate& boundary(int key) const {
            return point ? boundary_templates[std::size_t(key)] : span_templates[std::size_t(key)];
        }
    };

    LevelTemplates level_templates(int level) const {
        LevelTemplates lt;
        lt.level = level;
        lt.log2h = dom_.k - 1 - level / 3;
        const int cls = level % 3;
        const int32_t h = int32_t{1} << lt.log2h;
        lt.use = h <= kTemplateMaxH && 12 * h <= dom_.L;
        lt.point = h <= kPointTemplateMaxH;
        if (!lt.use) return lt;
        (lt.point ? lt.point_templates.resize(64) : lt.span_templates.resize(64));
        if (kExactInt && lt.point) lt.boundary_templates.resize(64);
        // In parallel: a small volume's encode spends a tenth of its time here,
        // before any row can start (each key fills its own entries).
        tbb::parallel_for(0, 64, [&](int r) {
            const int rr[3] = {r & 3, (r >> 2) & 3, (r >> 4) & 3};
            const int odd = (rr[0] & 1) + (rr[1] & 1) + (rr[2] & 1);
            if (3 - odd != cls) return;
            Pt rep{8 * h + rr[0] * h, 8 * h + rr[1] * h, 8 * h + rr[2] * h};
            const DiamondInfo d = classify_centre(rep, dom_.k);
            if (lt.point) lt.point_templates[std::size_t(r)] = make_template(rep, d);
            else lt.span_templates[std::size_t(r)] = make_span_template(rep, d);
            if (kExactInt && lt.point) lt.boundary_templates[std::size_t(r)] = make_span_template(rep, d);
        });
        return lt;
    }

    /// out(x, error before rounding) for the diamonds of lt.level centred at
    /// (x, y, z), x = x0, x0 + step, ... <= x1: a template when the diamond lies
    /// inside the data box, else a scan. The window must hold planes z - h ..
    /// z + h (clipped to B). The per-centre work of the
    /// finest levels is a handful of points, so what depends on the row only
    /// (the y and z tests, the template key's y and z parts) is done once here.
    template <class Out>
    void errors_along_row(const LevelTemplates& lt, int32_t x0, int32_t y, int32_t z, int32_t step, int32_t x1,
                          Out&& out) const {
        const int32_t h = int32_t{1} << lt.log2h;
        const auto& m = dom_.box_max;
        int32_t in_lo = x1 + 1, in_hi = x1;  // the centres whose diamond is inside B, if any
        if (lt.use && y - h >= 0 && z - h >= 0 && y + h <= m[1] && z + h <= m[2] && h <= m[0] - h) {
            in_lo = std::max(x0, h);
            in_lo = x0 + (in_lo - x0 + step - 1) / step * step;
            in_hi = std::min(x1, m[0] - h);
        }
        const int key_yz_all = (((y >> lt.log2h) & 3) << 2) | (((z >> lt.log2h) & 3) << 4);
        auto scan = [&](int32_t x) {
            const Pt c{x, y, z};
            if constexpr (kExactInt) {
                if (lt.use) return out(x, boundary_error(lt.boundary(((x >> lt.log2h) & 3) | key_yz_all), c));
            }
            out(x, diamond_error(c, classify_centre(c, dom_.k)));
        };
        int32_t x = x0;
        for (; x <= x1 && x < in_lo; x += step) scan(x);
        if (in_lo <= in_hi) {
            const int key_yz = (((y >> lt.log2h) & 3) << 2) | (((z >> lt.log2h) & 3) << 4);
            const int64_t row = index(Pt{0, y, z});
            if constexpr (kExactInt) {
                // Centres x and x + 2 step have the same template (x + 4h, same
                // residue mod 4h): evaluate them as pairs, four centres a round.
                if (lt.point) {
                    for (; x + 3 * step <= in_hi; x += 4 * step) {
                        for (int32_t xa = x; xa <= x + step; xa += step) {
                            const Template& tpl = lt.point_templates[((xa >> lt.log2h) & 3) | key_yz];
                            int64_t e[2];
                            eval_exact_pair(tpl, f_ + row + xa, f_ + row + xa + 2 * step, e);
                            out(xa, tpl.divide(double(e[0])));
                            out(xa + 2 * step, tpl.divide(double(e[1])));
                        }
                    }
                }
            }
            for (; x <= in_hi; x += step) {
                const int key = ((x >> lt.log2h) & 3) | key_yz;
                out(x, lt.point ? eval_template(lt.point_templates[key], row + x)
                                : eval_span_template(lt.span_templates[key], row + x));
            }
        }
        for (; x <= x1; x += step) scan(x);
    }

    /// Calls f(x0, y, z, step, x1) for every row of centres of `level` in the
    /// data box with z in zlo..zhi (centres x0, x0 + step, ... <= x1), in
    /// parallel (each row once: f may update state of its own centres without
    /// locks).
    template <class F>
    void for_level_rows(int level, int64_t zlo, int64_t zhi, F&& f, bool parallel = true) const {
        const auto& m = dom_.box_max;
        const int cls = level % 3;
        const int32_t h = int32_t{1} << (dom_.k - 1 - level / 3);
        // Centres of this level: coordinates that are odd multiples of h on
        // 3 - cls axes (the odd set) and multiples of 2h on the others.
        for (int odd_mask = 1; odd_mask < 8; ++odd_mask) {
            if (3 - std::popcount(unsigned(odd_mask)) != cls) continue;
            const int32_t first[3] = {(odd_mask & 1) ? h : 0, (odd_mask & 2) ? h : 0,
                                      (odd_mask & 4) ? h : 0};
            if (first[0] > m[0] || first[1] > m[1] || first[2] > m[2]) continue;
            const int64_t step = 2 * h;
            const int64_t top = std::min<int64_t>(zhi, m[2]);
            const int64_t iz0 = zlo <= first[2] ? 0 : (zlo - first[2] + step - 1) / step;
            const int64_t iz1 = top < first[2] ? -1 : (top - first[2]) / step;
            if (iz1 < iz0) continue;
            // Over planes and rows of centres: a slab may hold a single plane
            // of the larger diamonds' centres, which must still feed every core.
            const int64_t ny = (m[1] - first[1]) / step + 1;
            auto row = [&](int64_t iz, int64_t iy) {
                f(first[0], int32_t(first[1] + iy * step), int32_t(first[2] + iz * step), int32_t(step), m[0]);
            };
            if (!parallel) {
                for (int64_t iz = iz0; iz <= iz1; ++iz)
                    for (int64_t iy = 0; iy < ny; ++iy) row(iz, iy);
                continue;
            }
            tbb::parallel_for(tbb::blocked_range2d<int64_t>(iz0, iz1 + 1, 1, 0, ny, 8),
                              [&](const tbb::blocked_range2d<int64_t>& r) {
                                  for (int64_t iz = r.rows().begin(); iz < r.rows().end(); ++iz)
                                      for (int64_t iy = r.cols().begin(); iy < r.cols().end(); ++iy) row(iz, iy);
                              });
        }
    }

    /// Calls f(c) for every centre c of `level` in the data box with c.z in
    /// zlo..zhi, as for_level_rows.
    template <class F>
    void for_level_centres(int level, int64_t zlo, int64_t zhi, F&& f, bool parallel = true) const {
        for_level_rows(
            level, zlo, zhi,
            [&](int32_t x0, int32_t y, int32_t z, int32_t step, int32_t x1) {
                for (int32_t x = x0; x <= x1; x += step) f(Pt{x, y, z});
            },
            parallel);
    }

    static float round_up(double err, double slack) {
        if (std::isinf(err)) return std::numeric_limits<float>::infinity();
        if (err > 0) err += slack;
        float f = float(err);
        if (double(f) < err) f = std::nextafter(f, std::numeric_limits<float>::infinity());
        return f;
    }

    const HtDomain& domain() const { return dom_; }

private:
    const T* f_;
    const HtDomain& dom_;
    int64_t z0_, X_, XY_;
};

/// Calls f(Acc tag, slack) with the accumulator exact for the data (see
/// compute_diamond_errors) and the slack added to float errors.
template <class T, class F>
void with_accumulator(const HtDomain& domain, std::array<double, 2> range, F&& f) {
    if constexpr (std::is_integral_v<T>) {
        // Integers are evaluated exactly: in double while every term stays below
        // 2^53 (value bits + 3k + 4 bits), otherwise in 128-bit integers.
        if (int(8 * sizeof(T)) + 3 * domain.k + 4 <= 53) f(double{}, 0.0);
        else f(__int128{}, 0.0);
    } else {
        // Floats: rounding is unavoidable, so add a slack of a few ulps of the
        // largest magnitude to keep the stored bound conservative.
        f(double{}, 64 * DBL_EPSILON * std::max(std::abs(range[0]), std::abs(range[1])));
    }
}

}  // namespace tetlod::ht::error_detail
