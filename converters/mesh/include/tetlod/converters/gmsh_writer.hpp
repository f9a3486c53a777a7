#pragma once
// Gmsh MSH 4.1 writer (ASCII or binary), readable by Gmsh 4.x, meshio and
// every MSH 4.1 reader. One volume entity (dim 3, tag 1) holds every node and
// every tetrahedron (element type 4); node tags are vertex index + 1, element
// tags tet index + 1. No $Entities section (optional in MSH 4.1: Gmsh then
// creates a discrete volume). Data views:
//   $NodeData    "<mesh.field_name>": the field, one double per node;
//   $ElementData "level" and "error" (when the mesh has them), one double each.
// Binary files follow the 4.1 binary layout: section headers in ASCII, counts as
// size_t (8 bytes), dims/tags/types in entity headers as int, node and element
// tags as size_t, data-section tags as int, all little-endian (this machine's order,
// announced by the int 1 after the format line).
#include <memory>
#include <string>

#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"

namespace tetlod {

/// Writes `mesh` as a .msh 4.1 file, atomically. Points in world coordinates.
/// Throws tetlod::Error(InvalidArgument) on an inconsistent mesh, IoError when the
/// file cannot be written.
void write_gmsh(const TetMesh& mesh, const std::string& path, bool binary);
/// The same file written as the parts arrive (the data views after the
/// elements wait in temporary files beside `path`).
std::unique_ptr<TetMeshSink> open_gmsh_stream(const std::string& path, bool binary);

}  // namespace tetlod
