#pragma once
// An extracted tetrahedral mesh: the output of every selective-refinement query
// and the input of every mesh writer. Vertices are grid points (integer index
// coordinates) carrying the exact field value; geometry maps them to world space.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tetlod/core/volume.hpp"

namespace tetlod {

struct GridGeometry {
    Vec3 spacing{1.0, 1.0, 1.0};
    Vec3 origin{0.0, 0.0, 0.0};
    std::array<double, 3> world(const std::array<int32_t, 3>& p) const {
        return {origin[0] + spacing[0] * p[0], origin[1] + spacing[1] * p[1],
                origin[2] + spacing[2] * p[2]};
    }
};

struct TetMesh {
    GridGeometry geometry;
    std::string field_name = "value";
    /// Grid index coordinates of each vertex.
    std::vector<std::array<int32_t, 3>> points;
    /// Field value at each vertex (exact: a sample of the input).
    std::vector<double> values;
    /// The type of the samples `values` came from: every value is exactly
    /// representable in it, so writers may store them in it (a u8 volume's
    /// mesh keeps 1-byte values). F64 when unknown.
    ValueType value_type = ValueType::F64;
    /// Vertex ids; every tet is positively oriented in index space:
    /// (p1-p0) x (p2-p0) . (p3-p0) > 0.
    std::vector<std::array<uint32_t, 4>> tets;
    /// Per tet: refinement level in its model (0 = coarsest).
    std::vector<uint8_t> level;
    /// Per tet: the error bound the query judged it by (field units).
    std::vector<float> error;

    std::size_t tet_count() const { return tets.size(); }
    std::size_t vertex_count() const { return points.size(); }
};

}  // namespace tetlod
