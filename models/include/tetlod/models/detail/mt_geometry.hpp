#pragma once
// Exact grid geometry shared by the MT builder and extractor: orientation,
// barycentric numerators, the 5-tet reference mesh, the tet/box test, the shape
// ratio and the canonical order of a star (spec/mt-model.md §M1, §M2, §M5).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "tetlod/models/detail/tet_box_intersection.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::mt {

using Pt = std::array<int32_t, 3>;
inline constexpr uint32_t kNil = 0xFFFFFFFFu;

struct Grid {
    int64_t X = 0, Y = 0, Z = 0;
    explicit Grid(const Dims& d) : X(d.x), Y(d.y), Z(d.z) {}
    /// In unsigned 32 bits (indices and dims are below 2^32): a 64-bit signed
    /// division costs several times more, and an extraction's split asks for a
    /// hundred coordinates.
    Pt coord(uint32_t i) const {
        const uint32_t x = i % uint32_t(X), r = i / uint32_t(X);
        return {int32_t(x), int32_t(r % uint32_t(Y)), int32_t(r / uint32_t(Y))};
    }
    uint32_t index(int64_t x, int64_t y, int64_t z) const { return uint32_t((z * Y + y) * X + x); }
    /// Bit set of the box planes the point lies on (x=0, x=max, y=0, ...).
    uint8_t planes(const Pt& p) const {
        return uint8_t((p[0] == 0) | (p[0] == X - 1) << 1 | (p[1] == 0) << 2 | (p[1] == Y - 1) << 3 |
                       (p[2] == 0) << 4 | (p[2] == Z - 1) << 5);
    }
};

/// det[b-a, c-a, d-a] = 6 x signed volume (exact for coordinates below 2^20).
inline int64_t orient(const Pt& a, const Pt& b, const Pt& c, const Pt& d) {
    const int64_t bx = b[0] - a[0], by = b[1] - a[1], bz = b[2] - a[2];
    const int64_t cx = c[0] - a[0], cy = c[1] - a[1], cz = c[2] - a[2];
    const int64_t dx = d[0] - a[0], dy = d[1] - a[1], dz = d[2] - a[2];
    return bx * (cy * dz - cz * dy) - by * (cx * dz - cz * dx) + bz * (cx * dy - cy * dx);
}

/// The orientation of tet v with its corner k moved to p, as an affine function of p:
/// at(p) = g . p + h (at(v[k]) = orient(v)). An edge collapse that moves corner k of a
/// tet to a target is legal for that tet iff at(target) > 0, so one function per tet
/// tests every target of a star with a dot product.
struct CornerPlane {
    std::array<int64_t, 3> g{0, 0, 0};
    int64_t h = 0;
    int64_t at(const Pt& p) const { return g[0] * p[0] + g[1] * p[1] + g[2] * p[2] + h; }
};
/// corner_plane from the face opposite k alone: a, b, c are the other corners in slot
/// order. A caller that has the face's corners (a star walk) need not build the fourth.
inline CornerPlane corner_plane_of_face(const Pt& a, const Pt& b, const Pt& c, int k) {
    const int64_t sign = (k & 1) ? -1 : 1;
    const int64_t ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    const int64_t wx = c[0] - a[0], wy = c[1] - a[1], wz = c[2] - a[2];
    const int64_t nx = uy * wz - uz * wy, ny = uz * wx - ux * wz, nz = ux * wy - uy * wx;
    CornerPlane pl;
    pl.g = {-sign * nx, -sign * ny, -sign * nz};
    pl.h = sign * (a[0] * nx + a[1] * ny + a[2] * nz);
    return pl;
}
inline CornerPlane corner_plane(const std::array<Pt, 4>& v, int k) {
    // The face opposite k, oriented so that the sign alternates with k as in orient().
    static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    return corner_plane_of_face(v[size_t(kFace[k][0])], v[size_t(kFace[k][1])], v[size_t(kFace[k][2])], k);
}

/// Barycentric numerators of a positively oriented tet as affine functions:
/// D_i(p) = g_i . p + h_i, with sum D_i = det. Point p is in the closed tet iff all >= 0.
struct Bary {
    std::array<std::array<int64_t, 3>, 4> g;
    std::array<int64_t, 4> h;
    int64_t det = 0;

    void set(const std::array<Pt, 4>& v) {
        for (int i = 0; i < 4; ++i) set_face(v, i);
        det = orient(v[0], v[1], v[2], v[3]);
    }
    /// The same numerators for tet v whose corner k was just moved there from a tet that
    /// had the same face opposite k: `opposite` is that face's corner_plane (it does not
    /// depend on corner k) and `det` its value at v[k]. Exact integers, so equal to set(v).
    void set_moved(const std::array<Pt, 4>& v, int k, const CornerPlane& opposite, int64_t det_at_k) {
        for (int i = 0; i < 4; ++i)
            if (i != k) set_face(v, i);
        g[size_t(k)] = opposite.g;
        h[size_t(k)] = opposite.h;
        det = det_at_k;
    }
    // D_i: orient(p,a,b,c) = (a-p).N, N = (b-a)x(c-a): g = -N, h = a.N, over the face
    // opposite corner i (as corner_plane, whose signs alternate with i the same way).
    void set_face(const std::array<Pt, 4>& v, int i) {
        static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
        const Pt& a = v[size_t(kFace[i][0])];
        const Pt& b = v[size_t(kFace[i][1])];
        const Pt& c = v[size_t(kFace[i][2])];
        const int64_t sign = (i & 1) ? -1 : 1;
        const int64_t ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
        const int64_t wx = c[0] - a[0], wy = c[1] - a[1], wz = c[2] - a[2];
        const int64_t nx = uy * wz - uz * wy, ny = uz * wx - ux * wz, nz = ux * wy - uy * wx;
        g[size_t(i)] = {-sign * nx, -sign * ny, -sign * nz};
        h[size_t(i)] = sign * (a[0] * nx + a[1] * ny + a[2] * nz);
    }
    int64_t eval(int i, const Pt& p) const {
        return g[i][0] * p[0] + g[i][1] * p[1] + g[i][2] * p[2] + h[i];
    }
    /// Fills d and returns true when p lies in the closed tet.
    bool locate(const Pt& p, std::array<int64_t, 4>& d) const {
        for (int i = 0; i < 4; ++i) {
            d[i] = eval(i, p);
            if (d[i] < 0) return false;
        }
        return true;
    }
};

/// The 5 tets of every grid cell (spec/mt-model.md §M2): the 4 corners of even x+y+z form the
/// central tet, each odd corner a tet with its 3 neighbours. Face diagonals match
/// across cells. Positively oriented. `origin`: where g's point 0 sits in the whole
/// grid (a brick), so that the parity, hence the tets, are those of the whole grid.
/// Calls f(tet) for each, in the order reference_tets lists them: a brick builds its
/// records from them directly, without a list of them beside the records (16 B a tet,
/// 80 B per grid point, while the brick's own arrays fill).
template <class F>
void for_each_reference_tet(const Grid& g, const Pt& origin, F&& f) {
    const int64_t po = int64_t(origin[0]) + origin[1] + origin[2];
    for (int64_t k = 0; k + 1 < g.Z; ++k)
        for (int64_t j = 0; j + 1 < g.Y; ++j)
            for (int64_t i = 0; i + 1 < g.X; ++i) {
                std::array<uint32_t, 4> even{};
                int ne = 0;
                auto corner = [&](int c) { return g.index(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2)); };
                for (int c = 0; c < 8; ++c)
                    if (((po + i + (c & 1) + j + (c >> 1 & 1) + k + (c >> 2)) & 1) == 0) even[ne++] = corner(c);
                auto emit = [&](std::array<uint32_t, 4> t) {
                    if (orient(g.coord(t[0]), g.coord(t[1]), g.coord(t[2]), g.coord(t[3])) < 0)
                        std::swap(t[2], t[3]);
                    f(t);
                };
                emit(even);
                for (int c = 0; c < 8; ++c) {
                    if (((po + i + (c & 1) + j + (c >> 1 & 1) + k + (c >> 2)) & 1) == 0) continue;
                    emit({corner(c), corner(c ^ 1), corner(c ^ 2), corner(c ^ 4)});
                }
            }
}

inline std::vector<std::array<uint32_t, 4>> reference_tets(const Grid& g, const Pt& origin = {0, 0, 0}) {
    std::vector<std::array<uint32_t, 4>> out;
    out.reserve(size_t(5 * (g.X - 1) * (g.Y - 1) * (g.Z - 1)));
    for_each_reference_tet(g, origin, [&](const std::array<uint32_t, 4>& t) { out.push_back(t); });
    return out;
}

/// Exact closed tet / closed box intersection: shared with the HT through the
/// query's region test (tet_box_intersection.hpp).
using tetlod::geometry::tet_meets_box;

namespace detail {
inline std::array<double, 3> sub3(const std::array<double, 3>& u, const std::array<double, 3>& v) {
    return {u[0] - v[0], u[1] - v[1], u[2] - v[2]};
}
inline double dot3(const std::array<double, 3>& u, const std::array<double, 3>& v) {
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
}
}  // namespace detail

/// The squared length of the shortest edge of triangle p1 p2 p3: the part of
/// shape_ratio_squared that does not depend on p0, so a builder ranking many apexes
/// over one face computes it once.
inline double face_shortest_squared(const std::array<double, 3>& p1, const std::array<double, 3>& p2,
                                    const std::array<double, 3>& p3) {
    const auto e12 = detail::sub3(p2, p1), e13 = detail::sub3(p3, p1), e23 = detail::sub3(p3, p2);
    return std::min({detail::dot3(e12, e12), detail::dot3(e13, e13), detail::dot3(e23, e23)});
}

/// shape_ratio_squared with the face's shortest edge given (face_shortest_squared of
/// p1 p2 p3): the same value, bit for bit (a minimum does not depend on its grouping).
inline double shape_ratio_squared(const std::array<double, 3>& p0, const std::array<double, 3>& p1,
                                  const std::array<double, 3>& p2, const std::array<double, 3>& p3,
                                  double face_shortest) {
    auto cross = [](const std::array<double, 3>& u, const std::array<double, 3>& v) {
        return std::array<double, 3>{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                                     u[0] * v[1] - u[1] * v[0]};
    };
    const auto a = detail::sub3(p1, p0), b = detail::sub3(p2, p0), c = detail::sub3(p3, p0);
    const auto bc = cross(b, c), ca = cross(c, a), ab = cross(a, b);
    const double den = 2.0 * detail::dot3(a, bc);
    const double la = detail::dot3(a, a), lb = detail::dot3(b, b), lc = detail::dot3(c, c);
    std::array<double, 3> o;
    for (int k = 0; k < 3; ++k) o[k] = la * bc[k] + lb * ca[k] + lc * ab[k];
    const double shortest = std::min(std::min({la, lb, lc}), face_shortest);
    return detail::dot3(o, o) / (den * den * shortest);
}

/// The square of a tet's circumradius / shortest edge ratio, from physical coordinates:
/// one division and no square root, for ranking many candidate tets (the order of
/// squares is the order of ratios; regular tet: 6/16). The tet must be positively
/// oriented (den > 0).
inline double shape_ratio_squared(const std::array<double, 3>& p0, const std::array<double, 3>& p1,
                                  const std::array<double, 3>& p2, const std::array<double, 3>& p3) {
    return shape_ratio_squared(p0, p1, p2, p3, face_shortest_squared(p1, p2, p3));
}


/// A star tet's place in the canonical order (star_order): compared as integers,
/// field by field (a pair with a std::array compared through memcmp-like loops, and
/// sorting indices into the keys, took 7 % of an MT extraction).
struct StarKey {
    int64_t along;                // -(sum of the corners - 4 s).(w - s)
    std::array<uint32_t, 3> face;  // the face opposite s, sorted grid indices
    uint32_t at;                  // position in the star (equal keys only in a broken star)
    bool operator<(const StarKey& o) const {
        if (along != o.along) return along < o.along;
        if (face[0] != o.face[0]) return face[0] < o.face[0];
        if (face[1] != o.face[1]) return face[1] < o.face[1];
        if (face[2] != o.face[2]) return face[2] < o.face[2];
        return at < o.at;
    }
};

/// Canonical order of the star of node s for its split towards w (spec/mt-model.md §M5):
/// first by -(sum of the tet's corners - 4 s).(w - s) (tets leaning towards w come
/// first, so masks are mostly a prefix of ones), then by the sorted grid indices of
/// the face opposite s. Vertex ids must be in the order of the grid indices; `coord_of`
/// gives a vertex's grid coordinates. Returns the permutation (positions into `star`).
template <class CoordOf, class TetOf>
void star_order(const std::vector<uint32_t>& star, uint32_t s, const Pt& ps, const Pt& pw,
                CoordOf coord_of, TetOf tet_of, std::vector<uint32_t>& perm, std::vector<StarKey>& keys) {
    const int64_t dx = pw[0] - ps[0], dy = pw[1] - ps[1], dz = pw[2] - ps[2];
    keys.resize(star.size());
    for (size_t i = 0; i < star.size(); ++i) {
        const std::array<uint32_t, 4>& v = tet_of(star[i]);
        int64_t sx = 0, sy = 0, sz = 0;
        std::array<uint32_t, 3> f{};
        int nf = 0;
        for (int j = 0; j < 4; ++j) {
            const Pt p = coord_of(v[j]);
            sx += p[0] - ps[0], sy += p[1] - ps[1], sz += p[2] - ps[2];
            if (v[j] != s && nf < 3) f[nf++] = v[j];
        }
        if (f[0] > f[1]) std::swap(f[0], f[1]);
        if (f[1] > f[2]) std::swap(f[1], f[2]);
        if (f[0] > f[1]) std::swap(f[0], f[1]);
        keys[i] = StarKey{-(sx * dx + sy * dy + sz * dz), f, uint32_t(i)};
    }
    std::sort(keys.begin(), keys.end());
    perm.resize(star.size());
    for (size_t i = 0; i < star.size(); ++i) perm[i] = keys[i].at;
}

/// Rounds a nonnegative double up to a float that is >= it (inexact: one more ulp).
inline float round_up_float(double v, bool exact) {
    if (!(v > 0)) return 0.0f;
    float f = static_cast<float>(v);
    if (double(f) < v) f = std::nextafter(f, INFINITY);
    if (!exact) f = std::nextafter(f, INFINITY);
    return f;
}

}  // namespace tetlod::mt
