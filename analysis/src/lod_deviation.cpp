// The volume a LOD mesh represents and its deviation from the original (see
// lod_deviation.hpp).
#include "tetlod/analysis/lod_deviation.hpp"

#include <algorithm>
#include <cmath>

#include "tetlod/core/error.hpp"

namespace tetlod {

LodDeviation volume_deviation(const Volume& lod, const Volume& original) {
    LodDeviation d;
    double sum = 0;
    const int64_t n = original.dims.count();
    for (int64_t i = 0; i < n; ++i) {
        const double dev = std::fabs(lod.value(i) - original.value(i));
        if (std::isnan(dev)) continue;
        d.max = std::max(d.max, dev);
        sum += dev;
    }
    d.grid_points = uint64_t(n);
    d.mean = n ? sum / double(n) : 0.0;
    return d;
}

LodVolume lod_volume(const TetMesh& mesh, const Volume& original) {
    MeshResampleStats rs;
    LodVolume out{resample_mesh(mesh, original.dims, original.type, &rs), {}};
    if (rs.covered != rs.grid_points)
        throw Error(ErrorCode::CorruptData, "the LOD mesh leaves " +
                                                std::to_string(rs.grid_points - rs.covered) +
                                                " grid points uncovered");
    out.volume.spacing = original.spacing;
    out.volume.origin = original.origin;
    out.volume.field_name = original.field_name;
    out.volume.units = original.units;
    out.volume.metadata = original.metadata;
    out.deviation = volume_deviation(out.volume, original);
    for (float e : mesh.error) out.deviation.mesh_error = std::max(out.deviation.mesh_error, double(e));
    return out;
}

}  // namespace tetlod
