// Mesh format dispatcher: picks the table entry (mesh_format.hpp) from the
// format name or the file's extension, then calls its writer.
#include "tetlod/converters/mesh_writer.hpp"

#include <filesystem>

#include "tetlod/core/error.hpp"
#include "tetlod/core/output_policy.hpp"

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

namespace {

const MeshFormat& choose_format(const std::string& path, const std::string& format) {
    const MeshFormat* f = nullptr;
    if (!format.empty()) {
        f = find_mesh_format(format);
        if (!f)
            throw Error(ErrorCode::InvalidArgument, "'" + path + "': unknown mesh format '" + format +
                                                        "' (supported: " + joined_formats() + ")");
    } else {
        const std::string ext = std::filesystem::path(path).extension().string();
        if (path == "-")
            throw Error(ErrorCode::InvalidArgument,
                        "'-' (standard output) has no file extension: name the mesh format (the CLI's --format; "
                        "supported: " + joined_formats() + ")");
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
    return *f;
}

/// A format without a streaming writer: the parts are gathered, then written.
class GatheringSink final : public TetMeshSink {
public:
    GatheringSink(const MeshFormat& f, std::string path, MeshWriteOptions o)
        : f_(f), path_(std::move(path)), o_(o) {
        check_output(path_);  // refuse before any work, as the streaming writers do
    }
    void begin(const TetMesh& v, uint64_t n) override {
        checks_.begin("cannot write '" + path_ + "'", v.points.size(), n);
        collect_.begin(v, n);
    }
    void add(std::span<const std::array<uint32_t, 4>> t, std::span<const uint8_t> l,
             std::span<const float> e) override {
        checks_.batch(t, l.size(), e.size());
        collect_.add(t, l, e);
    }
    void finish() override {
        checks_.finish();
        f_.write(collect_.mesh, path_, o_);
    }

private:
    const MeshFormat& f_;
    std::string path_;
    MeshWriteOptions o_;
    TetMeshCollector collect_;
    StreamedTetChecks checks_;
};

}  // namespace

void write_tet_mesh(const TetMesh& mesh, const std::string& path, const std::string& format,
                    const MeshWriteOptions& options) {
    choose_format(path, format).write(mesh, path, options);
}

std::unique_ptr<TetMeshSink> open_mesh_stream(const std::string& path, const std::string& format,
                                              const MeshWriteOptions& options) {
    const MeshFormat& f = choose_format(path, format);
    if (f.open_stream) return f.open_stream(path, options);
    return std::make_unique<GatheringSink>(f, path, options);
}

std::vector<std::string> mesh_companion_files(const std::string& path) {
    const MeshFormat* f = mesh_format_for_path(path);
    if (!f || !f->companion_files) return {};
    return f->companion_files(path);
}

}  // namespace tetlod
