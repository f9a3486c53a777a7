#pragma once
// Exact tetrahedron / axis-aligned box tests by the separating axis theorem
// (box normals, tet face normals, tet edge x box axis), in integers.
#include <algorithm>
#include <array>
#include <cstdint>

#include "tetlod/models/detail/ht_geometry.hpp"

namespace tetlod::ht {

struct IBox {
    std::array<int64_t, 3> lo, hi;  // closed
};

namespace detail {
// Returns false when axis n separates the closed tet from the closed box;
// with `touching_separates`, also when they only touch along n.
inline bool overlap_on_axis(const Tet& t, const IBox& b, int64_t n0, int64_t n1, int64_t n2,
                            bool touching_separates) {
    if (n0 == 0 && n1 == 0 && n2 == 0) return true;
    int64_t tmin = INT64_MAX, tmax = INT64_MIN;
    for (const Pt& p : t) {
        const int64_t d = n0 * p[0] + n1 * p[1] + n2 * p[2];
        tmin = std::min(tmin, d), tmax = std::max(tmax, d);
    }
    const int64_t n[3] = {n0, n1, n2};
    int64_t bmin = 0, bmax = 0;
    for (int a = 0; a < 3; ++a) {
        const int64_t x = n[a] * b.lo[a], y = n[a] * b.hi[a];
        bmin += std::min(x, y), bmax += std::max(x, y);
    }
    if (touching_separates) return tmax > bmin && bmax > tmin;
    return tmax >= bmin && bmax >= tmin;
}

inline bool sat_overlap(const Tet& t, const IBox& b, bool touching_separates) {
    for (int a = 0; a < 3; ++a) {
        int64_t n[3] = {0, 0, 0};
        n[a] = 1;
        if (!overlap_on_axis(t, b, n[0], n[1], n[2], touching_separates)) return false;
    }
    static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    for (const auto& f : kFaces) {
        const Pt &p = t[f[0]], &q = t[f[1]], &r = t[f[2]];
        const int64_t u0 = q[0] - p[0], u1 = q[1] - p[1], u2 = q[2] - p[2];
        const int64_t v0 = r[0] - p[0], v1 = r[1] - p[1], v2 = r[2] - p[2];
        if (!overlap_on_axis(t, b, u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0,
                             touching_separates))
            return false;
    }
    static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    for (const auto& e : kEdges) {
        const int64_t d0 = t[e[1]][0] - t[e[0]][0], d1 = t[e[1]][1] - t[e[0]][1],
                      d2 = t[e[1]][2] - t[e[0]][2];
        // d x e_x = (0, d2, -d1); d x e_y = (-d2, 0, d0); d x e_z = (d1, -d0, 0)
        if (!overlap_on_axis(t, b, 0, d2, -d1, touching_separates)) return false;
        if (!overlap_on_axis(t, b, -d2, 0, d0, touching_separates)) return false;
        if (!overlap_on_axis(t, b, d1, -d0, 0, touching_separates)) return false;
    }
    return true;
}
}  // namespace detail

// (Closed tet meets closed box, the LOD query's test: tet_box_intersection.hpp.)

/// True when the interiors of tet and box intersect (touching does not count).
inline bool tet_interior_meets_box(const Tet& t, const IBox& b) {
    return detail::sat_overlap(t, b, /*touching_separates=*/true);
}

enum class BoxRelation : uint8_t { Inside, Crossing, Outside };

/// Where a tet lies relative to the data box B = [0, m0] x [0, m1] x [0, m2].
inline BoxRelation classify_against_data_box(const Tet& t, const std::array<int32_t, 3>& m) {
    bool inside = true;
    for (const Pt& p : t)
        if (p[0] > m[0] || p[1] > m[1] || p[2] > m[2]) inside = false;
    if (inside) return BoxRelation::Inside;  // tets never have negative coordinates
    // A point of the closed tet strictly inside B: the interiors meet (a
    // neighbourhood of the point, inside B, meets the tet's interior). The
    // vertices, the centroid, then the points of barycentric coordinates 2/5
    // towards each vertex (in integers: 1, 4 and 5 x the points). Nearly every
    // tet across B's far faces is decided here, without the 13 axes of the
    // full test.
    for (const Pt& p : t)
        if (p[0] > 0 && p[1] > 0 && p[2] > 0 && p[0] < m[0] && p[1] < m[1] && p[2] < m[2])
            return BoxRelation::Crossing;
    int64_t sum[3];
    bool centroid_inside = true;
    for (int a = 0; a < 3; ++a) {
        sum[a] = int64_t(t[0][a]) + t[1][a] + t[2][a] + t[3][a];
        centroid_inside = centroid_inside && sum[a] > 0 && sum[a] < 4 * int64_t(m[a]);
    }
    if (centroid_inside) return BoxRelation::Crossing;
    for (const Pt& p : t) {
        bool near_vertex_inside = true;
        for (int a = 0; a < 3; ++a) {
            const int64_t s5 = sum[a] + p[a];
            near_vertex_inside = near_vertex_inside && s5 > 0 && s5 < 5 * int64_t(m[a]);
        }
        if (near_vertex_inside) return BoxRelation::Crossing;
    }
    IBox b{{0, 0, 0}, {m[0], m[1], m[2]}};
    return tet_interior_meets_box(t, b) ? BoxRelation::Crossing : BoxRelation::Outside;
}

}  // namespace tetlod::ht
