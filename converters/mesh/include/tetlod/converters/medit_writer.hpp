#pragma once
// Medit .mesh writer (ASCII, MeshVersionFormatted 2 = double precision), the
// format of Medit, MMG, TetGen's -g output and meshio, with the field in a
// companion .sol file (SolAtVertices, one scalar per vertex) beside it: Medit
// and MMG load FILE.sol automatically with FILE.mesh. Tetrahedra carry the
// refinement level as their reference number; vertices carry reference 0.
// Vertex ids in the file are 1-based, as the format requires.
#include <string>

#include "tetlod/core/tet_mesh.hpp"

namespace tetlod {

/// The .sol path that goes with a .mesh path (extension replaced).
std::string medit_sol_path(const std::string& mesh_path);

/// Writes `mesh` to `path` (.mesh) and the field to medit_sol_path(path), each
/// atomically. Throws tetlod::Error(InvalidArgument) on an inconsistent mesh,
/// IoError when a file cannot be written.
void write_medit(const TetMesh& mesh, const std::string& path);

}  // namespace tetlod
