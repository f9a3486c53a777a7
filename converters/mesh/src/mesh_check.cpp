#include "mesh_check.hpp"

#include "tetlod/core/error.hpp"

namespace tetlod::detail {

void check_tet_mesh(const TetMesh& mesh, const std::string& path) {
    auto fail = [&](const std::string& what) {
        throw Error(ErrorCode::InvalidArgument, "cannot write '" + path + "': " + what);
    };
    const std::size_t np = mesh.points.size();
    const std::size_t nt = mesh.tets.size();
    if (mesh.values.size() != np)
        fail(std::to_string(mesh.values.size()) + " values for " + std::to_string(np) + " points");
    if (!mesh.level.empty() && mesh.level.size() != nt)
        fail(std::to_string(mesh.level.size()) + " levels for " + std::to_string(nt) + " tets");
    if (!mesh.error.empty() && mesh.error.size() != nt)
        fail(std::to_string(mesh.error.size()) + " errors for " + std::to_string(nt) + " tets");
    for (std::size_t t = 0; t < nt; ++t)
        for (uint32_t v : mesh.tets[t])
            if (v >= np)
                fail("tet " + std::to_string(t) + " uses vertex " + std::to_string(v) + " of " +
                     std::to_string(np));
}

}  // namespace tetlod::detail
