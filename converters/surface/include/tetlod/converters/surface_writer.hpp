#pragma once
// Triangle-surface writers (isosurfaces) for the tools users already have:
//   .ply  Stanford PLY, binary little-endian (default) or ASCII: vertex x y z
//         (float) and face vertex_indices (uchar count, int ids), nothing
//         else: the plain layout every reader copes with (gmsh 4.8 misreads
//         binary vertices with normals, meshio 5 binary faces with more
//         properties). With SurfaceWriteOptions::ply_extras: vertex nx ny nz
//         (float) and per face "error" (float: error bound of the source tet)
//         and "surface" (int: index of the isovalue);
//   .obj  Wavefront OBJ with vertex normals (vn);
//   .off  Object File Format, plain OFF (no normals: NOFF is refused by common
//         readers such as meshio);
//   .stl  STL, binary (default) or ASCII, with facet normals.
// Written through OpenMesh's IO (the only place in tetlod that includes it),
// atomically (temporary file beside the target, then rename). OBJ/OFF/STL carry
// no per-face scalars, so the error is only in PLY with ply_extras.
#include <string>
#include <vector>

#include "tetlod/core/triangle_mesh.hpp"

namespace tetlod {

struct SurfaceWriteOptions {
    /// Binary PLY/STL (ignored by OBJ and OFF, which are text only).
    bool binary = true;
    /// Write vertex normals (OBJ; PLY only with ply_extras; facet normals in
    /// STL are always written).
    bool normals = true;
    /// PLY only: vertex normals and per-face "error" and "surface". Off by
    /// default: gmsh 4.8 cannot read them in binary PLY, nor meshio 5 the faces.
    bool ply_extras = false;
};

/// Formats write_surface accepts, as names that are also the file extensions.
std::vector<std::string> surface_format_names();

/// Writes `surface` to `path`. `format` is one of surface_format_names(); empty
/// means from the extension (case-insensitive). Throws tetlod::Error:
/// InvalidArgument for an unknown format or an inconsistent mesh (face ids out
/// of range, per-vertex/per-face arrays of the wrong size), IoError when the file
/// cannot be written.
void write_surface(const TriangleMesh& surface, const std::string& path,
                   const std::string& format = "", const SurfaceWriteOptions& options = {});

}  // namespace tetlod
