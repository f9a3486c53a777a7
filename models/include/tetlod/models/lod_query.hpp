#pragma once
// A selective-refinement query, the same for every model (HT, MT): which error
// bound each tetrahedron of the output must honour.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace tetlod {

struct LodQuery {
    static constexpr double kUnbounded = std::numeric_limits<double>::infinity();

    /// Bound inside the region of interest (everywhere for a uniform query).
    /// Negative: full resolution. +inf: as coarse as conformity allows.
    double error_in = kUnbounded;
    /// Bound outside the region (only used when a region is given).
    double error_out = kUnbounded;
    /// Region part 1: an axis-aligned box in index coordinates, inclusive:
    /// x0,y0,z0,x1,y1,z1. A tet is in it when the closed tet meets the closed box.
    std::optional<std::array<int64_t, 6>> box;
    /// Region part 2: isovalues. A tet is in it when one of them lies in the
    /// conservative value range of the tet (see the model's documentation).
    std::vector<double> isovalues;
    /// When both a box and isovalues are given, a tet is in the region only
    /// if it meets the box AND may be crossed by an isosurface.

    /// The full-resolution reference mesh of the model, regardless of errors.
    bool full = false;

    bool has_region() const { return box.has_value() || !isovalues.empty(); }
};

}  // namespace tetlod
