#pragma once
// Isosurfaces of an extracted tetrahedral mesh by marching tetrahedra: the
// field is linear on each tet, so the surface f = V is planar inside each tet
// (a triangle or a quadrilateral cut into two triangles).
//
// Conventions (what callers may rely on):
//  - Inside / outside: a vertex is INSIDE when f >= V, outside when f < V. A
//    sample exactly equal to V therefore counts as inside, which is a symbolic
//    perturbation (V lowered by an infinitesimal): no vertex is ever "on" the
//    surface, every crossed edge has one inside and one outside end, and the
//    surface is combinatorially the boundary of the inside region. On a
//    conforming mesh it is closed (every edge in exactly two triangles) except
//    where it meets the mesh boundary, and it is a 2-manifold. Where samples
//    equal V, distinct surface vertices can coincide in space (zero-area
//    triangles); they are never merged, so the topology stays manifold.
//  - Welding: one surface vertex per crossed mesh edge, keyed by the edge's
//    two vertex ids (and the isovalue), so neighbouring tets share vertices.
//  - Orientation: triangles are counter-clockwise seen from OUTSIDE (f < V);
//    face normals and vertex normals point out of the region f >= V, i.e.
//    towards DECREASING field (normal = -gradient / |gradient|). For density
//    data (bright = solid) this is the usual outward normal.
//  - Vertex gradient: the volume-weighted mean of the (constant) gradients of
//    the crossed tets around the vertex's edge, in world units.
//  - Face error: mesh.error of the source tet (0 when the mesh has no errors).
//  - Several isovalues go into one TriangleMesh; face_surface says which.
#include <span>

#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/triangle_mesh.hpp"

namespace tetlod {

struct IsosurfaceStats {
    uint64_t crossed_tets = 0;
    uint64_t degenerate_faces = 0;  // faces dropped: they used a vertex twice after welding
    uint64_t cancelled_faces = 0;   // faces dropped: opposite pairs on the same three vertices
    uint64_t welded_vertices = 0;   // vertices merged into another at the same position
    uint64_t split_vertices = 0;    // copies made so that every vertex is one fan
    uint64_t zero_area_faces = 0;   // kept faces of zero computed area (rounding; normally 0)
};

/// Marching tetrahedra on `mesh` for each of `isovalues` (any order; duplicates
/// give duplicate surfaces). Output in world coordinates (mesh.geometry).
/// Throws tetlod::Error(InvalidArgument) when the mesh is inconsistent (array
/// sizes, vertex ids out of range) or an isovalue is NaN, or more than 65535
/// isovalues are given. Linear in the number of tets.
TriangleMesh marching_tetrahedra(const TetMesh& mesh, std::span<const double> isovalues,
                                 IsosurfaceStats* stats = nullptr);

/// Signed volume enclosed by a closed, consistently oriented surface
/// (divergence theorem): positive when normals point outwards.
double enclosed_volume(const TriangleMesh& surface);

}  // namespace tetlod
