// The one list of built-in tetrahedral mesh formats, and the table built from
// it. A new format defines its entry beside its writer and adds one line below
// (the order of help texts).
#include <algorithm>
#include <cctype>
#include <filesystem>

#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

MeshFormat vtu_mesh_format();
MeshFormat vtk_legacy_mesh_format();
MeshFormat gmsh_ascii_mesh_format();
MeshFormat gmsh_binary_mesh_format();
MeshFormat medit_mesh_format();

namespace {

std::deque<MeshFormat> built_in_formats() {
    return {
        vtu_mesh_format(),
        vtk_legacy_mesh_format(),
        gmsh_ascii_mesh_format(),
        gmsh_binary_mesh_format(),
        medit_mesh_format(),
    };
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

std::deque<MeshFormat>& table() {
    static std::deque<MeshFormat> t = built_in_formats();
    return t;
}

}  // namespace

const std::deque<MeshFormat>& mesh_formats() { return table(); }

const MeshFormat* find_mesh_format(const std::string& name) {
    const std::string n = lower(name);
    for (const auto& f : table())
        if (f.name == n) return &f;
    return nullptr;
}

const MeshFormat* mesh_format_for_path(const std::string& path) {
    const std::string ext = lower(std::filesystem::path(path).extension().string());
    if (ext.empty()) return nullptr;
    for (const auto& f : table())
        if (std::find(f.extensions.begin(), f.extensions.end(), ext) != f.extensions.end()) return &f;
    return nullptr;
}

void register_mesh_format(MeshFormat format) {
    auto taken = [](const std::string& what) {
        throw Error(ErrorCode::InvalidArgument, "register_mesh_format: '" + what + "' is already taken");
    };
    if (format.name.empty()) throw Error(ErrorCode::InvalidArgument, "register_mesh_format: no name");
    format.name = lower(format.name);
    for (auto& e : format.extensions) e = lower(e);
    if (find_mesh_format(format.name)) taken(format.name);
    for (const auto& e : format.extensions)
        if (mesh_format_for_path("x" + e)) taken(e);
    if (format.built && !format.write)
        throw Error(ErrorCode::InvalidArgument, "register_mesh_format: '" + format.name + "' has no writer");
    table().push_back(std::move(format));
}

std::string mesh_format_summary() {
    std::string s;
    for (const auto& f : table()) {
        if (f.extensions.empty()) continue;  // chosen only by name
        std::string item;
        for (const auto& e : f.extensions) item += (item.empty() ? "" : "/") + e;
        if (!f.description.empty()) item += " " + f.description;
        if (!f.built) item += " (not built)";
        s += (s.empty() ? "" : ", ") + item;
    }
    return s;
}

}  // namespace tetlod
