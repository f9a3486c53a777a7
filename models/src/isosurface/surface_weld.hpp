#pragma once
// Clean-up of a raw marching-tetrahedra surface where samples equal the
// isovalue (internal to the isosurface code; conventions in isosurface.hpp).
#include <cstdint>
#include <vector>

#include "tetlod/models/isosurface.hpp"

namespace tetlod::detail {

/// A surface under construction: `mesh.gradients` holds weighted gradient
/// SUMS, `weight` their weights; `vertex_surface` the isovalue index of each
/// vertex. weld_surface() keeps these in step with the vertices it merges,
/// copies and removes.
struct RawSurface {
    TriangleMesh& mesh;
    std::vector<double>& weight;
    std::vector<uint16_t>& vertex_surface;
};

/// In order: (1) merges vertices of one surface at exactly the same position;
/// (2) drops faces that use a vertex twice (zero area: they cancel out of every
/// edge count, so the orientation of what is left stays consistent); (3)
/// removes pairs of faces with the same three vertices and opposite
/// orientations (a two-sided sheet of zero thickness, where the inside region
/// is a single layer of samples equal to V); (4) splits a vertex whose faces
/// form several fans (the surface touches itself at that point; faces sharing
/// an edge used by more than two faces count as separate fans) into one vertex
/// per fan, so every vertex is manifold; (5) removes unused vertices.
void weld_surface(RawSurface s, IsosurfaceStats& stats);

}  // namespace tetlod::detail
