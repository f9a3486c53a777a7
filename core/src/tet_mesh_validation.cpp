#include "tetlod/core/tet_mesh_validation.hpp"

#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"

namespace tetlod {

namespace {

// Six times the signed volume in index space. Coordinate differences need 33
// bits, their triple product up to 99: exact in 128-bit integers.
__int128 six_volume(const TetMesh& m, const std::array<uint32_t, 4>& t) {
    __int128 d[3][3];
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) d[i][a] = int64_t(m.points[t[i + 1]][a]) - int64_t(m.points[t[0]][a]);
    return d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1]) - d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0]) +
           d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]);
}

std::string to_string(__int128 v) {
    if (v == 0) return "0";
    const bool negative = v < 0;
    std::string s;
    while (v != 0) {
        const int digit = int(v % 10);
        s.insert(s.begin(), char('0' + (digit < 0 ? -digit : digit)));
        v /= 10;
    }
    return negative ? "-" + s : s;
}

}  // namespace

std::string tet_mesh_problem(const TetMesh& mesh, const TetMeshChecks& checks) {
    const std::size_t np = mesh.points.size();
    const std::size_t nt = mesh.tets.size();
    if (mesh.values.size() != np)
        return std::to_string(mesh.values.size()) + " values for " + std::to_string(np) + " points";
    if (!mesh.level.empty() && mesh.level.size() != nt)
        return std::to_string(mesh.level.size()) + " levels for " + std::to_string(nt) + " tets";
    if (!mesh.error.empty() && mesh.error.size() != nt)
        return std::to_string(mesh.error.size()) + " errors for " + std::to_string(nt) + " tets";
    for (std::size_t t = 0; t < nt; ++t)
        for (uint32_t v : mesh.tets[t])
            if (v >= np)
                return "tet " + std::to_string(t) + " uses vertex " + std::to_string(v) + " of " +
                       std::to_string(np) + " points";
    if (checks.orientation)
        for (std::size_t t = 0; t < nt; ++t) {
            const __int128 v6 = six_volume(mesh, mesh.tets[t]);
            if (v6 <= 0)
                return "tet " + std::to_string(t) + " is degenerate or inverted (6 x volume = " + to_string(v6) +
                       " in grid units)";
        }
    return {};
}

void validate(const TetMesh& mesh, const std::string& context, const TetMeshChecks& checks) {
    const std::string problem = tet_mesh_problem(mesh, checks);
    if (!problem.empty()) throw Error(ErrorCode::InvalidArgument, context + ": " + problem);
}

void validate_vertices(const TetMesh& v, const std::string& context) {
    if (v.values.size() != v.points.size())
        throw Error(ErrorCode::InvalidArgument, context + ": " + std::to_string(v.values.size()) + " values for " +
                                                    std::to_string(v.points.size()) + " points");
}

void check_tets(std::span<const std::array<uint32_t, 4>> tets, std::size_t points, const std::string& context,
                uint64_t first) {
    for (std::size_t t = 0; t < tets.size(); ++t)
        for (uint32_t v : tets[t])
            if (v >= points)
                throw Error(ErrorCode::InvalidArgument, context + ": tet " + std::to_string(first + t) +
                                                            " uses vertex " + std::to_string(v) + " of " +
                                                            std::to_string(points) + " points");
}

void StreamedTetChecks::presence(std::size_t tets, std::size_t n, int& has) const {
    if (tets == 0) return;
    const int now = n == 0 ? 0 : 1;
    if ((n != 0 && n != tets) || (has >= 0 && has != now))
        throw Error(ErrorCode::InvalidArgument, context_ + ": level and error must come with every tet or never");
    has = now;
}

void StreamedTetChecks::batch(std::span<const std::array<uint32_t, 4>> tets, std::size_t levels,
                              std::size_t errors) {
    check_tets(tets, points_, context_, added_);
    if (added_ + tets.size() > announced_)
        throw Error(ErrorCode::InvalidArgument, context_ + ": more tets than announced");
    presence(tets.size(), levels, level_);
    presence(tets.size(), errors, error_);
    added_ += tets.size();
}

void StreamedTetChecks::finish() const {
    if (added_ != announced_)
        throw Error(ErrorCode::InvalidArgument, context_ + ": " + std::to_string(added_) + " tets came, " +
                                                    std::to_string(announced_) + " were announced");
}

}  // namespace tetlod
