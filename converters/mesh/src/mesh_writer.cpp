// Mesh format dispatcher: picks the table entry (mesh_format.hpp) from the
// format name or the file's extension, then calls its writer.
#include "tetlod/converters/mesh_writer.hpp"

#include <filesystem>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

std::string joined_formats() {
    std::string r;
    for (const auto& f : mesh_format_names()) r += (r.empty() ? "" : ", ") + f;
    return r;
}

}  // namespace

std::vector<std::string> mesh_format_names() {
    std::vector<std::string> names;
    for (const auto& f : mesh_formats()) names.push_back(f.name);
    return names;
}

void write_tet_mesh(const TetMesh& mesh, const std::string& path, const std::string& format,
                    const MeshWriteOptions& options) {
    const MeshFormat* f = nullptr;
    if (!format.empty()) {
        f = find_mesh_format(format);
        if (!f)
            throw Error(ErrorCode::InvalidArgument, "'" + path + "': unknown mesh format '" + format +
                                                        "' (supported: " + joined_formats() + ")");
    } else {
        const std::string ext = std::filesystem::path(path).extension().string();
        if (ext.empty() || ext == ".")
            throw Error(ErrorCode::InvalidArgument,
                        "'" + path +
                            "': no file extension to choose a mesh format from "
                            "(supported: " +
                            joined_formats() + ")");
        f = mesh_format_for_path(path);
        if (!f)
            throw Error(ErrorCode::InvalidArgument, "'" + path + "': unknown mesh format '" + ext.substr(1) +
                                                        "' (supported: " + joined_formats() + ")");
    }
    if (!f->built)
        throw Error(ErrorCode::NotBuilt, "'" + path + "': this tetlod was built without the " + f->name + " writer");
    f->write(mesh, path, options);
}

std::vector<std::string> mesh_companion_files(const std::string& path) {
    const MeshFormat* f = mesh_format_for_path(path);
    if (!f || !f->companion_files) return {};
    return f->companion_files(path);
}

}  // namespace tetlod
