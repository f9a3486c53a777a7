#pragma once
// One entry point for every tetrahedral mesh format, chosen by name or by the
// output file's extension, so tools never need to know the individual writers.
#include <string>
#include <vector>

#include "tetlod/core/tet_mesh.hpp"

namespace tetlod {

struct MeshWriteOptions {
    /// Compress where the format allows it (.vtu); ignored by the others.
    bool compress = true;
};

/// Formats write_tet_mesh accepts, as names that are also the file extensions
/// (vtu, vtk, msh = Gmsh 4.1 ASCII, mesh = Medit + .sol), plus "msh-binary"
/// (Gmsh 4.1 binary, only by name).
std::vector<std::string> mesh_format_names();

/// Writes `mesh` to `path` atomically. `format` is one of mesh_format_names();
/// empty means "from the extension of path" (case-insensitive). Throws
/// tetlod::Error(InvalidArgument) for an unknown format or extension, naming the
/// supported ones, and whatever the chosen writer throws.
void write_tet_mesh(const TetMesh& mesh, const std::string& path, const std::string& format = "",
                    const MeshWriteOptions& options = {});

}  // namespace tetlod
