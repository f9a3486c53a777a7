#pragma once
// Shape quality of tetrahedra: the circumradius-to-shortest-edge ratio used by
// the paper (regular tet: sqrt(6)/4 ~ 0.612; larger is worse; flat tets: +inf).
// Measured in world coordinates (spacing applied): the ratio is not affine
// invariant, so anisotropic grids change it.
#include <array>
#include <cstdint>
#include <vector>

#include "tetlod/core/tet_mesh.hpp"

namespace tetlod {

using WorldTet = std::array<std::array<double, 3>, 4>;

/// Circumradius / shortest edge of one tet; +inf when degenerate.
double circumradius_to_shortest_edge(const WorldTet& t);

struct ShapeQualityStats {
    uint64_t count = 0;
    double min = 0, mean = 0, max = 0;
    /// Histogram of the ratio over [hist_lo, hist_hi) in equal bins; values above
    /// go to the last bin.
    double hist_lo = 0.5, hist_hi = 2.5;
    std::vector<uint64_t> histogram;
};

ShapeQualityStats shape_quality(const TetMesh& mesh, int bins = 20);

}  // namespace tetlod
