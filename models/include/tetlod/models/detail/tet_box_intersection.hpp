#pragma once
// Exact closed tetrahedron / closed axis-aligned box intersection by the
// separating axis theorem: axis normals in 64-bit integers (exact while
// coordinate differences stay below 2^31), projections in 128-bit ones. The one
// box test of the LOD query's region, for both models.
#include <algorithm>
#include <array>
#include <cstdint>

namespace tetlod::geometry {

/// Exact closed tet / closed box intersection (separating axis theorem).
inline bool tet_meets_box(const std::array<std::array<int32_t, 3>, 4>& t, const std::array<int64_t, 3>& lo,
                          const std::array<int64_t, 3>& hi) {
    for (int a = 0; a < 3; ++a) {
        int64_t mn = t[0][a], mx = t[0][a];
        for (int i = 1; i < 4; ++i) mn = std::min<int64_t>(mn, t[i][a]), mx = std::max<int64_t>(mx, t[i][a]);
        if (mx < lo[a] || mn > hi[a]) return false;
    }
    // A vertex in the box is a common point: most tets a box query meets have one,
    // and the 13 axes below cost ~30 128-bit products each.
    for (const auto& v : t)
        if (v[0] >= lo[0] && v[0] <= hi[0] && v[1] >= lo[1] && v[1] <= hi[1] && v[2] >= lo[2] && v[2] <= hi[2])
            return true;
    auto separated = [&](const std::array<int64_t, 3>& n) {
        if (n[0] == 0 && n[1] == 0 && n[2] == 0) return false;
        __int128 tmn = 0, tmx = 0;
        for (int i = 0; i < 4; ++i) {
            const __int128 v = __int128(n[0]) * t[i][0] + __int128(n[1]) * t[i][1] + __int128(n[2]) * t[i][2];
            if (i == 0 || v < tmn) tmn = v;
            if (i == 0 || v > tmx) tmx = v;
        }
        __int128 bmn = 0, bmx = 0;
        for (int a = 0; a < 3; ++a) {
            const __int128 x = __int128(n[a]) * lo[a], y = __int128(n[a]) * hi[a];
            bmn += std::min(x, y), bmx += std::max(x, y);
        }
        return tmx < bmn || tmn > bmx;
    };
    static constexpr int E[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    std::array<std::array<int64_t, 3>, 6> e;
    for (int i = 0; i < 6; ++i)
        for (int a = 0; a < 3; ++a) e[i][a] = int64_t(t[E[i][1]][a]) - t[E[i][0]][a];
    auto cross = [](const std::array<int64_t, 3>& u, const std::array<int64_t, 3>& v) {
        return std::array<int64_t, 3>{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                                      u[0] * v[1] - u[1] * v[0]};
    };
    // Face normals of the tet.
    static constexpr int F[4][2] = {{0, 1}, {0, 2}, {3, 4}, {1, 2}};  // edge pairs spanning faces
    // faces: (0,1,2): e01 x e02; (0,1,3): e01 x e03; (1,2,3): e12 x e13; (0,2,3): e02 x e03
    const std::array<std::array<int64_t, 3>, 4> fn = {cross(e[0], e[1]), cross(e[0], e[2]),
                                                      cross(e[3], e[4]), cross(e[1], e[2])};
    (void)F;
    for (const auto& n : fn)
        if (separated(n)) return false;
    for (int a = 0; a < 3; ++a) {
        std::array<int64_t, 3> ax{0, 0, 0};
        ax[a] = 1;
        for (int i = 0; i < 6; ++i)
            if (separated(cross(ax, e[i]))) return false;
    }
    return true;
}

}  // namespace tetlod::geometry
