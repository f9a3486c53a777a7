// Medit .mesh / .sol writer. Layout from the Medit documentation (P. Frey,
// "MEDIT: an interactive mesh visualization software", INRIA RT-0253) and
// libMeshb's keyword list: free-format ASCII keywords, each followed by a count
// and that many records; "End" closes the file.
#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/converters/medit_writer.hpp"

#include <cstdio>
#include <filesystem>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"
#include "tetlod/core/output_policy.hpp"

namespace tetlod {

namespace {

void appendf(std::string& s, const char* fmt, double a, double b, double c) {
    char buf[96];
    const int n = std::snprintf(buf, sizeof buf, fmt, a, b, c);
    s.append(buf, static_cast<std::size_t>(n));
}

}  // namespace

std::string medit_sol_path(const std::string& mesh_path) {
    return std::filesystem::path(mesh_path).replace_extension(".sol").string();
}

void write_medit(const TetMesh& mesh, const std::string& path) {
    if (is_std_stream(path))
        throw Error(ErrorCode::InvalidArgument,
                    "Medit cannot be written to standard output ('-'): the field goes to a .sol file "
                    "beside the .mesh; give a file name or another format");
    validate(mesh, "cannot write '" + path + "'");
    std::string s;
    s.reserve(mesh.points.size() * 64 + mesh.tets.size() * 40 + 256);
    s += "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n";
    s += std::to_string(mesh.points.size()) + "\n";
    for (const auto& p : mesh.points) {
        const auto w = mesh.geometry.world(p);
        appendf(s, "%.17g %.17g %.17g 0\n", w[0], w[1], w[2]);
    }
    s += "\nTetrahedra\n" + std::to_string(mesh.tets.size()) + "\n";
    for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
        const auto& t = mesh.tets[i];
        s += std::to_string(t[0] + 1ull) + ' ' + std::to_string(t[1] + 1ull) + ' ' +
             std::to_string(t[2] + 1ull) + ' ' + std::to_string(t[3] + 1ull) + ' ' +
             std::to_string(mesh.level.empty() ? 0 : int(mesh.level[i])) + '\n';
    }
    s += "\nEnd\n";

    std::string sol;
    sol.reserve(mesh.values.size() * 24 + 128);
    sol += "MeshVersionFormatted 2\n\nDimension 3\n\nSolAtVertices\n";
    sol += std::to_string(mesh.values.size()) + "\n1 1\n";  // one field, type 1 = scalar
    char buf[40];
    for (double v : mesh.values) {
        const int n = std::snprintf(buf, sizeof buf, "%.17g\n", v);
        sol.append(buf, static_cast<std::size_t>(n));
    }
    sol += "\nEnd\n";

    // Both files pass the output policy before either is committed; the .sol is
    // committed first so a reader that finds the .mesh finds its field too.
    AtomicFile sol_file(medit_sol_path(path));
    AtomicFile mesh_file(path);
    sol_file.write(sol);
    mesh_file.write(s);
    sol_file.commit();
    mesh_file.commit();
}

MeshFormat medit_mesh_format() {
    MeshFormat f;
    f.name = "mesh";
    f.extensions = {".mesh"};
    f.description = "(Medit + .sol)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) { write_medit(m, path); };
    f.companion_files = [](const std::string& path) { return std::vector<std::string>{medit_sol_path(path)}; };
    return f;
}

}  // namespace tetlod
