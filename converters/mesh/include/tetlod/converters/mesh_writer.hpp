#pragma once
// One entry point for every tetrahedral mesh format, chosen by name or by the
// output file's extension through the table of formats (mesh_format.hpp), so
// tools never need to know the individual writers.
#include <memory>
#include <string>
#include <vector>

#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/core/tet_mesh.hpp"

namespace tetlod {

/// Names write_tet_mesh accepts as `format`: every entry of mesh_formats()
/// (vtu, vtk, msh = Gmsh 4.1 ASCII, msh-binary = Gmsh 4.1 binary, only by
/// name, mesh = Medit + .sol).
std::vector<std::string> mesh_format_names();

/// Writes `mesh` to `path` atomically. `format` is one of mesh_format_names();
/// empty means "from the extension of path" (case-insensitive). Throws
/// tetlod::Error(InvalidArgument) for an unknown format or extension, naming the
/// supported ones, and whatever the chosen writer throws.
void write_tet_mesh(const TetMesh& mesh, const std::string& path, const std::string& format = "",
                    const MeshWriteOptions& options = {});

/// A sink writing to `path` in the chosen format (as write_tet_mesh chooses
/// it) as the parts arrive: streaming for the formats that can (.vtu, .vtk,
/// .msh), gathered and written at finish() for the others. Throws like
/// write_tet_mesh (an unknown format, a refused output) before any work.
std::unique_ptr<TetMeshSink> open_mesh_stream(const std::string& path, const std::string& format = "",
                                              const MeshWriteOptions& options = {});

/// Files write_tet_mesh(mesh, path) creates besides `path` (Medit's .sol);
/// empty for an unknown extension.
std::vector<std::string> mesh_companion_files(const std::string& path);

}  // namespace tetlod
