#pragma once
// Rasterisation of a tetrahedral mesh back onto a regular grid: the volume a
// level-of-detail mesh represents, every grid point linearly interpolated in the
// tet that contains it.
//
// Exactness: mesh vertices are integer grid points, so for a grid point p in a
// tet (v0..v3) the barycentric coordinates are N_i(p) / D with integer numerators
// N_i (signed volumes with v_i replaced by p) and D = sum N_i > 0, computed exactly
// in 128-bit integers.
//  - Integer value types: the value is the rational sum(N_i f_i) / D, rounded to
//    nearest (ties towards +inf) and clamped to the type's range. Exact: a point
//    gets the same value from every tet containing it (on a shared face or edge the
//    rational is the same), and where the interpolant equals the data the data
//    comes back unchanged. With an integer error bound E the rounded value stays
//    within E of an integer sample; with a fractional E within E rounded to nearest.
//  - Float types: lambda_i = double(N_i) / double(D) (correctly rounded, so the
//    same rational gives the same double in every tet), summed in increasing vertex
//    id order in double, then cast to the type. Canonical, so shared faces agree.
//    Exact for |N_i|, |D| < 2^53 (tets of side below ~2^17 grid steps).
// Cost: O(grid points covered + tets + scanned rows of each tet's bounding box):
// each tet visits only its own grid points, row by row (x-interval per (y, z) row
// solved exactly from the four numerators), never all points per tet.
#include <cstdint>

#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

struct MeshResampleStats {
    uint64_t grid_points = 0;   // points of the output grid
    uint64_t covered = 0;       // of which inside at least one tet
    uint64_t degenerate_tets = 0;  // tets of zero volume (skipped)
    // Work done (the cost above, counted, so tests can check it without timing):
    uint64_t rows_scanned = 0;    // (y, z) rows of the tets' clipped bounding boxes
    uint64_t points_visited = 0;  // grid points inside a tet, summed over tets
};

/// The volume of `dims` x `type` that `mesh` represents: each grid point inside a
/// tet gets the interpolated value (see above); points outside every tet stay 0
/// (counted in stats). Vertices and tets outside the grid are clipped. The result
/// takes spacing, origin and field name from the mesh. Throws tetlod::Error
/// (InvalidArgument) on invalid dims or vertex ids out of range.
Volume resample_mesh(const TetMesh& mesh, const Dims& dims, ValueType type,
                     MeshResampleStats* stats = nullptr);

}  // namespace tetlod
