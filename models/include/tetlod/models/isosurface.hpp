#pragma once
// Isosurfaces of an extracted tetrahedral mesh by marching tetrahedra: the
// field is linear on each tet, so the surface f = V is planar inside each tet
// (a triangle or a quadrilateral cut into two triangles).
//
// Conventions (what callers may rely on):
//  - Inside / outside: a vertex is INSIDE when f >= V, outside when f < V. A
//    sample exactly equal to V therefore counts as inside, which is a symbolic
//    perturbation (V lowered by an infinitesimal): every crossed edge has one
//    inside and one outside end, and the raw surface is combinatorially the
//    boundary of the inside region.
//  - Vertices: one per crossed mesh edge, keyed by the edge's two vertex ids
//    (per isovalue), so neighbouring tets share vertices. Where the inside end
//    equals V the vertex IS that sample: one vertex per sample, shared by all
//    its crossed edges.
//  - Welding (samples equal to V): vertices of one surface at bit-identical
//    positions are merged; faces that then use a vertex twice (zero area) are
//    dropped, and so are pairs of faces on the same three vertices with
//    opposite orientations (a zero-thickness sheet); a vertex where several
//    fans of faces meet (the surface touches itself at a sample) is split into
//    one vertex per fan, each moved 1/1000 of the way towards its fan's other
//    vertices, so no two vertices coincide.
//    An edge in more than two faces (two sheets meeting along an edge between
//    samples equal to V) joins no fans, so its ends split per sheet too.
//  - Guarantees (checked in tests/converters/surface): no face uses a vertex
//    twice, no two vertices of a surface share a position, every vertex is a
//    single fan, and every directed edge is matched by its reverse (closed and
//    consistently oriented) except where the surface meets the mesh boundary.
//    Away from samples equal to V the surface is a closed 2-manifold on a
//    conforming mesh. Not guaranteed: an edge in more than two faces whose
//    ends are single fans anyway (IsosurfaceStats::nonmanifold_edges counts
//    them; none in the tests' volumes, bucky at 128 included).
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
    uint64_t nonmanifold_edges = 0; // edges left in more than two faces (normally 0; see above)
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
