#pragma once
// A selective-refinement query, the same for every model (HT, MT): which error
// bound each tetrahedron of the output must honour.
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

namespace tetlod {

class QueryRegion;  // tetlod/models/query_region.hpp

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
    /// Region part 3: further regions (a sphere, or a program's own; see
    /// tetlod/models/query_region.hpp). A tet is in each when it meets it.
    std::vector<std::shared_ptr<const QueryRegion>> regions;
    /// When several parts are given, a tet is in the region only if it is in
    /// every part (e.g. meets the box AND may be crossed by an isosurface).

    /// The full-resolution reference mesh of the model, regardless of errors.
    bool full = false;

    bool has_region() const { return box.has_value() || !isovalues.empty() || !regions.empty(); }
};

}  // namespace tetlod
