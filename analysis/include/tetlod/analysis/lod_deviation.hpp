#pragma once
// How far a level-of-detail mesh is from the volume it approximates: the mesh
// resampled onto the grid (every grid point interpolated in its tet, see
// mesh_resample.hpp) and compared with the original, point by point.
// Works on trusted in-memory data.
#include <cstdint>

#include "tetlod/analysis/mesh_resample.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

struct LodDeviation {
    double max = 0, mean = 0;  // absolute deviation over the grid points (NaN points skipped)
    uint64_t grid_points = 0;
    double mesh_error = 0;     // largest error bound the mesh's tets carry
};

struct LodVolume {
    Volume volume;             // the volume the mesh represents, described like the original
    LodDeviation deviation;
};

/// Resamples `mesh` onto `original`'s grid and type, copies the original's
/// description (spacing, origin, field name, units, metadata) and measures the
/// deviation. Throws tetlod::Error(CorruptData) when the mesh leaves grid
/// points uncovered.
LodVolume lod_volume(const TetMesh& mesh, const Volume& original);

/// Max and mean absolute deviation of `lod` from `original` (same dims).
LodDeviation volume_deviation(const Volume& lod, const Volume& original);

}  // namespace tetlod
