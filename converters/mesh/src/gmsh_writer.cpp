// Gmsh MSH 4.1 writer. Layout from the Gmsh reference manual, "MSH file format"
// (version 4.1): $MeshFormat, $Nodes and $Elements in entity blocks, then
// post-processing views ($NodeData / $ElementData: 1 string tag = view name,
// 1 real tag = time, 3 integer tags = time step, components, count).
#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/converters/gmsh_writer.hpp"

#include <cstdio>
#include <cstring>
#include <memory>
#include <span>
#include <vector>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/spill_file.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"

namespace tetlod {

namespace {

// Emits numbers as ASCII tokens or as raw little-endian binary, so one code path
// writes both variants of each section.
class MshOut {
public:
    explicit MshOut(bool binary) : binary_(binary) {}
    void text(const std::string& s) { buf_ += s; }
    void size(uint64_t v) {
        if (binary_) raw(v); else token(std::to_string(v));
    }
    void integer(int32_t v) {
        if (binary_) raw(v); else token(std::to_string(v));
    }
    void real(double v) {
        if (binary_) {
            raw(v);
        } else {
            char b[32];
            const int n = std::snprintf(b, sizeof b, "%.17g", v);
            token(std::string(b, static_cast<std::size_t>(n)));
        }
    }
    /// Ends a record (ASCII: newline; binary: nothing).
    void eol() {
        if (!binary_) buf_ += '\n';
        line_start_ = true;
    }
    /// Closes a section: binary data is followed by a newline before $End...
    void end(const char* name) {
        if (binary_) buf_ += '\n';
        buf_ += std::string("$End") + name + "\n";
        line_start_ = true;
    }
    bool binary() const { return binary_; }
    const std::string& bytes() const { return buf_; }
    /// Writes what was put to `out` once it exceeds `threshold` bytes (0: always).
    template <class Out>
    void drain_to(Out& out, std::size_t threshold = 0) {
        if (buf_.size() < threshold) return;
        out.write(buf_.data(), buf_.size());
        buf_.clear();
    }

private:
    template <class T>
    void raw(const T& v) {
        char b[sizeof(T)];
        std::memcpy(b, &v, sizeof(T));
        buf_.append(b, sizeof(T));
    }
    void token(const std::string& s) {
        if (!line_start_) buf_ += ' ';
        buf_ += s;
        line_start_ = false;
    }
    bool binary_;
    bool line_start_ = true;
    std::string buf_;
};

// A view header: the tags are ASCII in both modes.
void view_header(MshOut& o, const char* section, const std::string& name, std::size_t count) {
    o.text(std::string("$") + section + "\n1\n\"" + name + "\"\n1\n0\n3\n0\n1\n" +
           std::to_string(count) + "\n");
}

constexpr std::size_t kDrainBytes = std::size_t{1} << 20;

/// The streaming writer: nodes and elements go to the file as they come; the
/// data views after them wait in temporary files (the node data formatted
/// already, level and error as raw values to format at the end).
class GmshSink final : public TetMeshSink {
public:
    GmshSink(const std::string& path, bool binary)
        : path_(path), binary_(binary), out_(path), o_(binary), node_data_(path), level_(path), error_(path) {}

    void begin(const TetMesh& v, uint64_t tet_count) override {
        validate_vertices(v, "cannot write '" + path_ + "'");
        np_ = v.points.size();
        nt_ = tet_count;
        if ((np_ > 0x7fffffffu || nt_ > 0x7fffffffu) && binary_)
            throw Error(ErrorCode::TooLarge,
                        "'" + path_ + "': more than 2^31 nodes or elements (MSH data tags are int)");
        o_.text(binary_ ? "$MeshFormat\n4.1 1 8\n" : "$MeshFormat\n4.1 0 8\n");
        if (binary_) {
            const int32_t one = 1;  // lets readers detect the byte order
            char b[4];
            std::memcpy(b, &one, 4);
            o_.text(std::string(b, 4));
        }
        o_.end("MeshFormat");
        o_.text("$Nodes\n");
        o_.size(np_ ? 1 : 0), o_.size(np_), o_.size(np_ ? 1 : 0), o_.size(np_), o_.eol();
        if (np_) {
            o_.integer(3), o_.integer(1), o_.integer(0), o_.size(np_), o_.eol();  // dim, tag, parametric
            for (std::size_t i = 0; i < np_; ++i) {
                o_.size(i + 1), o_.eol();
                o_.drain_to(out_, kDrainBytes);
            }
            for (const auto& p : v.points) {
                const auto w = v.geometry.world(p);
                o_.real(w[0]), o_.real(w[1]), o_.real(w[2]), o_.eol();
                o_.drain_to(out_, kDrainBytes);
            }
        }
        o_.end("Nodes");
        // The node data view, formatted now (the values are not kept).
        MshOut d(binary_);
        view_header(d, "NodeData", v.field_name, np_);
        for (std::size_t i = 0; i < np_; ++i) {
            d.integer(static_cast<int32_t>(i + 1));
            d.real(v.values[i]);
            d.eol();
            d.drain_to(node_data_, kDrainBytes);
        }
        d.end("NodeData");
        d.drain_to(node_data_);
        o_.text("$Elements\n");
        o_.size(nt_ ? 1 : 0), o_.size(nt_), o_.size(nt_ ? 1 : 0), o_.size(nt_), o_.eol();
        if (nt_) o_.integer(3), o_.integer(1), o_.integer(4), o_.size(nt_), o_.eol();  // type 4: 4-node tet
        o_.drain_to(out_);
        checks_.begin("cannot write '" + path_ + "'", np_, nt_);
    }

    void add(std::span<const std::array<uint32_t, 4>> tets, std::span<const uint8_t> level,
             std::span<const float> error) override {
        const uint64_t first = checks_.added();
        checks_.batch(tets, level.size(), error.size());
        for (std::size_t i = 0; i < tets.size(); ++i) {
            o_.size(first + i + 1);
            for (uint32_t v : tets[i]) o_.size(uint64_t(v) + 1);
            o_.eol();
            o_.drain_to(out_, kDrainBytes);
        }
        o_.drain_to(out_);
        level_.write(level.data(), level.size_bytes());
        error_.write(error.data(), error.size_bytes());
    }

    void finish() override {
        checks_.finish();
        o_.end("Elements");
        o_.drain_to(out_);
        node_data_.copy_to(out_);
        if (checks_.level()) element_view<uint8_t>("level", level_);
        if (checks_.error()) element_view<float>("error", error_);
        out_.commit();
    }

private:
    template <class T>
    void element_view(const char* name, SpillFile& values) {
        view_header(o_, "ElementData", name, nt_);
        uint64_t tag = 0;
        values.read_back([&](const std::byte* data, std::size_t size) {
            for (std::size_t k = 0; k + sizeof(T) <= size; k += sizeof(T)) {
                T v;
                std::memcpy(&v, data + k, sizeof(T));
                o_.integer(static_cast<int32_t>(++tag));
                o_.real(double(v));
                o_.eol();
                o_.drain_to(out_, kDrainBytes);
            }
        });
        o_.end("ElementData");
        o_.drain_to(out_);
    }

    std::string path_;
    bool binary_;
    AtomicFile out_;
    MshOut o_;
    SpillFile node_data_, level_, error_;
    std::size_t np_ = 0;
    uint64_t nt_ = 0;
    StreamedTetChecks checks_;
};

}  // namespace

std::unique_ptr<TetMeshSink> open_gmsh_stream(const std::string& path, bool binary) {
    return std::make_unique<GmshSink>(path, binary);
}

void write_gmsh(const TetMesh& mesh, const std::string& path, bool binary) {
    validate(mesh, "cannot write '" + path + "'");
    send_mesh(mesh, *open_gmsh_stream(path, binary));
}

MeshFormat gmsh_ascii_mesh_format() {
    MeshFormat f;
    f.name = "msh";
    f.extensions = {".msh"};
    f.description = "(Gmsh 4.1)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) { write_gmsh(m, path, false); };
    f.open_stream = [](const std::string& path, const MeshWriteOptions&) { return open_gmsh_stream(path, false); };
    return f;
}

MeshFormat gmsh_binary_mesh_format() {
    MeshFormat f;
    f.name = "msh-binary";
    f.description = "(Gmsh 4.1 binary)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) { write_gmsh(m, path, true); };
    f.open_stream = [](const std::string& path, const MeshWriteOptions&) { return open_gmsh_stream(path, true); };
    return f;
}

}  // namespace tetlod
