#pragma once
// Exact closed-error checks of one tet against a stated bound, shared by the
// brute-force bound checks of both models (mt_bound_check.cpp, ht_bound_check.cpp).
// Internal to analysis/: written from the spec's definitions alone (the closed error
// of a tet: max |f(p) - L_T(p)| over the grid points p of the closed tet), sharing no
// code with models/ or codecs/, whose stored errors it checks.
//
// Geometry: a tet with integer corners P0..P3 and D = det[P1-P0, P2-P0, P3-P0] > 0
// has, for a grid point p, barycentric numerators N_i(p) = g_i . p + c_i (g_i the
// normal of the face opposite P_i, oriented so N_i(P_i) = D), N_i(p) >= 0 for all
// i exactly when p is in the closed tet, and sum N_i = D. So
//     D (f(p) - L_T(p)) = D f(p) - sum N_i f(P_i) =: X(p)
// and the closed error is max |X(p)| / D. The requirement "stored >= error + E"
// is D stored - D E - |X(p)| >= 0 at every point.
//
// Exactness: with corners below 2^13 per axis, |g_i|, |c_i| and D fit 64 bits, and
// D < 2^40.
//  - Integer fields: X in 64-bit (8/16-bit types) or 128-bit integers (32-bit
//    types); the largest |X| of a tet is compared once with the bound.
//  - Float fields: X in double with an error bound; a point passes there when even
//    the bound's worst case holds, else the comparison is made exactly by
//    floating-point expansions (Knuth's two-sum, a fused multiply-add for the exact
//    product, Shewchuk's "grow expansion" with zero elimination; Shewchuk, "Adaptive
//    precision floating-point arithmetic and fast robust geometric predicates", 1997):
//    the expansion's sign is that of its largest component. Doubles suffice when
//    every value is 0 or within 2^-900..2^900 (no product or sum leaves the normal
//    range); otherwise the expansion is formed in binary128, where each product of a
//    40-bit integer and a double is exact and no sum over- or underflows.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "tetlod/core/volume.hpp"

namespace tetlod::exact_tet {

#if defined(__SIZEOF_FLOAT128__)
using Quad = __float128;
#else
using Quad = long double;
static_assert(std::numeric_limits<long double>::digits >= 113 && std::numeric_limits<long double>::min_exponent < -16000,
              "the exact fallback needs binary128");
#endif

using i128 = __int128;

// ---- exact sign of D s - D E - |sum a_k b_k| ---------------------------------

/// A nonoverlapping expansion, components in increasing magnitude, zeros dropped.
template <class T>
struct Expansion {
    T c[24];
    int n = 0;
    /// Adds b exactly (grow expansion: two-sum of b with every component).
    void add(T b) {
        T q = b;
        int m = 0;
        for (int i = 0; i < n; ++i) {
            const T s = q + c[i];
            const T bv = s - q;
            const T av = s - bv;
            const T h = (q - av) + (c[i] - bv);
            q = s;
            if (h != T(0)) c[m++] = h;
        }
        if (q != T(0)) c[m++] = q;
        n = m;
    }
    /// Adds a * b exactly: a is an integer below 2^53, b a double.
    void add_product(T a, T b) {
        const T p = a * b;
        add(p);
        if constexpr (std::is_same_v<T, double>) {
            add(std::fma(a, b, -p));  // the product's rounding error, exact in the normal range
        }  // binary128: a 53-bit times a 53-bit significand fits its 113 bits, p is exact
    }
    int sign() const { return n == 0 ? 0 : (c[n - 1] > T(0) ? 1 : -1); }
};

struct Terms {  // X = sum a[k] * b[k]
    double a[5], b[5];
    int n = 0;
};

template <class T>
bool holds_in(const Terms& x, double D, double stored, double E) {
    Expansion<T> X;
    for (int k = 0; k < x.n; ++k) X.add_product(T(x.a[k]), T(x.b[k]));
    const int sx = X.sign();
    Expansion<T> Y;
    for (int i = 0; i < X.n; ++i) Y.add(sx > 0 ? -X.c[i] : X.c[i]);  // -|X|
    Y.add_product(T(D), T(stored));
    Y.add_product(T(D), T(-E));
    return Y.sign() >= 0;
}

inline bool double_safe(double v) {
    const double a = std::fabs(v);
    return a == 0 || (a >= 0x1p-900 && a <= 0x1p900);
}

/// Exactly: D stored - D E - |X| >= 0. Values finite, D < 2^40, the a's integers below 2^53.
inline bool holds_exactly(const Terms& x, double D, double stored, double E) {
    if (std::isinf(stored)) return true;
    bool safe = double_safe(stored) && double_safe(E);
    for (int k = 0; k < x.n; ++k) safe = safe && double_safe(x.b[k]);
    return safe ? holds_in<double>(x, D, stored, E) : holds_in<Quad>(x, D, stored, E);
}

/// A sure pass without exact arithmetic: xhi >= |X| (a bound computed in double, any
/// rounding already in it), and D (stored - E) exceeds it even after the worst
/// roundings of the subtraction and the product (a relative 2^-48 covers them).
inline bool surely_holds(double xhi, double D, double stored, double E) {
    const double r = stored - E;
    return r > 0 && xhi * (1 + 0x1p-48) <= D * r * (1 - 0x1p-48);
}

// ---- geometry -----------------------------------------------------------------

struct TetGeometry {
    std::array<std::array<int64_t, 3>, 4> g{};  // N_i(p) = g_i . p + c_i
    std::array<int64_t, 4> c{};
    std::array<int64_t, 3> lo{}, hi{};  // bounding box
    int64_t D = 0;
};

inline TetGeometry geometry(const std::array<std::array<int64_t, 3>, 4>& P) {
    TetGeometry t;
    for (int i = 0; i < 4; ++i) {
        const auto& a = P[(i + 1) & 3];
        const auto& b = P[(i + 2) & 3];
        const auto& e = P[(i + 3) & 3];
        const int64_t ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
        const int64_t vx = e[0] - a[0], vy = e[1] - a[1], vz = e[2] - a[2];
        std::array<int64_t, 3> n{uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
        const int64_t s = n[0] * (P[i][0] - a[0]) + n[1] * (P[i][1] - a[1]) + n[2] * (P[i][2] - a[2]);
        if (s < 0)
            for (auto& v : n) v = -v;
        t.g[i] = n;
        t.c[i] = -(n[0] * a[0] + n[1] * a[1] + n[2] * a[2]);
        if (i == 0) t.D = s < 0 ? -s : s;
    }
    for (int k = 0; k < 3; ++k) {
        t.lo[k] = std::min({P[0][k], P[1][k], P[2][k], P[3][k]});
        t.hi[k] = std::max({P[0][k], P[1][k], P[2][k], P[3][k]});
    }
    return t;
}

inline int64_t floor_div(int64_t a, int64_t b) {  // b > 0
    int64_t q = a / b;
    if (a % b != 0 && a < 0) --q;
    return q;
}
inline int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

/// Calls f(index, N) for every grid point of the closed tet, row by row. A row's
/// x-interval is solved from the four numerators (integer divisions) when the tet is
/// wide; a narrow one (most tets of a refinement span a few cells) is scanned across
/// its bounding box with a sign test instead, which is cheaper than the divisions.
template <class F>
void for_each_point(const TetGeometry& t, const Dims& dims, F&& f) {
    const int64_t width = t.hi[0] - t.lo[0];
    const bool narrow = width <= 8;
    for (int64_t z = t.lo[2]; z <= t.hi[2]; ++z)
        for (int64_t y = t.lo[1]; y <= t.hi[1]; ++y) {
            std::array<int64_t, 4> r;  // N_i at (lo.x, y, z)
            int64_t xl = 0, xh = width;  // relative to lo.x
            for (int i = 0; i < 4; ++i) {
                r[i] = t.g[i][0] * t.lo[0] + t.g[i][1] * y + t.g[i][2] * z + t.c[i];
                if (narrow) continue;
                const int64_t gx = t.g[i][0];
                if (gx > 0) xl = std::max(xl, ceil_div(-r[i], gx));
                else if (gx < 0) xh = std::min(xh, floor_div(r[i], -gx));
                else if (r[i] < 0) xh = xl - 1;
            }
            const int64_t row = dims.index(t.lo[0], y, z);
            for (int64_t x = xl; x <= xh; ++x) {
                const std::array<int64_t, 4> N{r[0] + t.g[0][0] * x, r[1] + t.g[1][0] * x, r[2] + t.g[2][0] * x,
                                               r[3] + t.g[3][0] * x};
                if (narrow && (N[0] | N[1] | N[2] | N[3]) < 0) continue;  // outside: some N_i < 0
                f(row + x, N);
            }
        }
}

// ---- one tet against its bound ---------------------------------------------------

struct TetBoundOutcome {
    bool finite = true;  // false: a non-finite value at a corner or grid point (not checked)
    bool holds = true;   // stored >= closed error + E, decided exactly
    double exact = 0;    // the closed error (to ~1e-15 relative for floats)
    int64_t at = 0;      // grid index of a point where |f - L_T| is largest
    uint64_t points = 0;             // grid points evaluated
    uint64_t exact_comparisons = 0;  // comparisons the double filter could not decide
};

/// Checks stored >= (closed error of the tet) + E exactly. `corner` holds the grid
/// indices of the tet's corners, `t` its geometry (D > 0), `f` the field over `dims`.
/// stored = +inf always holds; E >= 0 finite.
template <class V>
TetBoundOutcome check_tet_bound(const V* f, const Dims& dims, const std::array<int64_t, 4>& corner,
                                const TetGeometry& t, double stored, double e) {
    TetBoundOutcome out;
    out.at = corner[0];
    std::array<V, 4> fv;
    for (int i = 0; i < 4; ++i) fv[i] = f[corner[i]];
    const double D = double(t.D);
    if constexpr (std::is_integral_v<V>) {
        // |X| < 2 D 2^32 < 2^73 for 32-bit types; < 2^57 otherwise.
        using Acc = std::conditional_t<(sizeof(V) >= 4), i128, int64_t>;
        Acc worst = 0;
        for_each_point(t, dims, [&](int64_t p, const std::array<int64_t, 4>& N) {
            ++out.points;
            Acc x = Acc(t.D) * Acc(f[p]);
            for (int i = 0; i < 4; ++i) x -= Acc(N[i]) * Acc(fv[i]);
            if (x < 0) x = -x;
            if (x > worst) worst = x, out.at = p;
        });
        out.exact = double(worst) / D;
        if (!(worst == 0 && stored >= e) && !surely_holds(double(worst) * (1 + 0x1p-52), D, stored, e)) {
            const i128 w = i128(worst);  // < 2^106: two exact doubles
            Terms x;
            x.a[0] = 1, x.b[0] = double(int64_t(w & ((i128(1) << 53) - 1)));
            x.a[1] = 0x1p53, x.b[1] = double(int64_t(w >> 53));
            x.n = 2;
            out.holds = holds_exactly(x, D, stored, e);
            ++out.exact_comparisons;
        }
    } else {
        for (int i = 0; i < 4; ++i)
            if (!std::isfinite(double(fv[i]))) {
                out.finite = false;
                return out;
            }
        for_each_point(t, dims, [&](int64_t p, const std::array<int64_t, 4>& N) {
            ++out.points;
            if (!out.finite) return;
            const double fp = double(f[p]);
            if (!std::isfinite(fp)) {
                out.finite = false;
                return;
            }
            // At a corner X = D f - D f = 0; with equal values X = f (D - sum N) = 0.
            if (N[0] == t.D || N[1] == t.D || N[2] == t.D || N[3] == t.D) return;
            if (fp == fv[0] && fp == fv[1] && fp == fv[2] && fp == fv[3]) return;
            double s = 0, a = 0;
            for (int i = 0; i < 4; ++i) {
                const double term = double(N[i]) * double(fv[i]);
                s += term;
                a += std::fabs(term);
            }
            const double head = D * fp;
            const double xt = std::fabs(head - s);
            // |X - xt| <= 5 u (|D f| + sum |N_i f_i|) (+ underflow): 2^-50 of it covers it.
            const double xhi = xt + (std::fabs(head) + a) * 0x1p-50 + 0x1p-1060;
            if (xt / D > out.exact) out.exact = xt / D, out.at = p;
            if (!std::isfinite(xhi)) {
                // Beyond the double range: only the exact test can tell.
            } else if (surely_holds(xhi, D, stored, e)) {
                return;
            }
            Terms x;
            x.a[0] = D, x.b[0] = fp;
            for (int i = 0; i < 4; ++i) x.a[1 + i] = -double(N[i]), x.b[1 + i] = double(fv[i]);
            x.n = 5;
            ++out.exact_comparisons;
            if (!holds_exactly(x, D, stored, e)) out.holds = false;
        });
    }
    return out;
}

}  // namespace tetlod::exact_tet
