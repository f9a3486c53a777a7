#pragma once
// The one consistency check of a TetMesh, used by every consumer that indexes
// its arrays (mesh writers, marching tetrahedra, resampling): a mesh built by
// hand or read from outside must never make them read past an array.
#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "tetlod/core/tet_mesh.hpp"

namespace tetlod {

struct TetMeshChecks {
    /// Also require every tet to be positively oriented in index space, as
    /// TetMesh promises for extracted meshes: (p1-p0) x (p2-p0) . (p3-p0) > 0.
    /// Off by default: resampling counts and skips degenerate tets instead.
    bool orientation = false;
};

/// The first inconsistency of `mesh`, or "" when there is none, naming the
/// array and index: "9 values for 10 points", "3 levels for 4 tets",
/// "3 errors for 4 tets", "tet 5 uses vertex 12 of 10 points",
/// "tet 5 is degenerate or inverted (6 x volume = -2 in grid units)".
std::string tet_mesh_problem(const TetMesh& mesh, const TetMeshChecks& checks = {});

/// Throws tetlod::Error(InvalidArgument) "<context>: <problem>" when
/// tet_mesh_problem finds one. `context` names the caller and file, e.g.
/// "cannot write 'out.vtu'" or "isosurface".
void validate(const TetMesh& mesh, const std::string& context, const TetMeshChecks& checks = {});

/// The parts of validate() a streaming consumer can check as parts arrive:
/// the vertices (values per point), then each batch of tets against the
/// vertex count (`first` numbers the batch's first tet in messages).
void validate_vertices(const TetMesh& vertices, const std::string& context);
void check_tets(std::span<const std::array<uint32_t, 4>> tets, std::size_t points, const std::string& context,
                uint64_t first = 0);

}  // namespace tetlod
