#pragma once
// Consistency checks shared by the mesh writers (internal header): a writer must
// never emit a file that points past its own arrays.
#include <string>

#include "tetlod/core/tet_mesh.hpp"

namespace tetlod::detail {

/// Throws tetlod::Error(InvalidArgument), naming `path`, when values, level or
/// error do not match the point/tet counts (level and error may be empty) or a
/// tet refers to a vertex that does not exist.
void check_tet_mesh(const TetMesh& mesh, const std::string& path);

}  // namespace tetlod::detail
