#include "tetlod/converters/mesh_writer.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "tetlod/converters/gmsh_writer.hpp"
#include "tetlod/converters/medit_writer.hpp"
#include "tetlod/converters/vtk_writers.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

std::string joined_formats() {
    std::string r;
    for (const auto& f : mesh_format_names()) r += (r.empty() ? "" : ", ") + f;
    return r;
}

}  // namespace

// "msh-binary" is the one name that is not an extension: .msh files are ASCII
// unless it is asked for.
std::vector<std::string> mesh_format_names() {
    return {"vtu", "vtk", "msh", "msh-binary", "mesh"};
}

void write_tet_mesh(const TetMesh& mesh, const std::string& path, const std::string& format,
                    const MeshWriteOptions& options) {
    std::string f = lower(format);
    if (f.empty()) {
        f = lower(std::filesystem::path(path).extension().string());
        if (!f.empty() && f[0] == '.') f.erase(0, 1);
        if (f.empty())
            throw Error(ErrorCode::InvalidArgument,
                        "'" + path +
                            "': no file extension to choose a mesh format from "
                            "(supported: " +
                            joined_formats() + ")");
    }
    if (f == "vtu") {
        VtuWriteOptions vo;
        vo.compress = options.compress;
        write_vtu(mesh, path, vo);
    } else if (f == "vtk") {
        write_vtk_legacy(mesh, path);
    } else if (f == "msh" || f == "msh-binary") {
        write_gmsh(mesh, path, f == "msh-binary");
    } else if (f == "mesh") {
        write_medit(mesh, path);
    } else {
        throw Error(ErrorCode::InvalidArgument, "'" + path + "': unknown mesh format '" + f +
                                                    "' (supported: " + joined_formats() + ")");
    }
}

}  // namespace tetlod
