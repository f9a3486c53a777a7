// Gmsh MSH 4.1 writer. Layout from the Gmsh reference manual, "MSH file format"
// (version 4.1): $MeshFormat, $Nodes and $Elements in entity blocks, then
// post-processing views ($NodeData / $ElementData: 1 string tag = view name,
// 1 real tag = time, 3 integer tags = time step, components, count).
#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/converters/gmsh_writer.hpp"

#include <cstdio>
#include <cstring>
#include <vector>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
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

template <class Get>
void view(MshOut& o, const char* section, const std::string& name, std::size_t count, Get get) {
    view_header(o, section, name, count);
    for (std::size_t i = 0; i < count; ++i) {
        // Data-section tags are int in the binary layout.
        o.integer(static_cast<int32_t>(i + 1));
        o.real(get(i));
        o.eol();
    }
    o.end(section);
}

}  // namespace

void write_gmsh(const TetMesh& mesh, const std::string& path, bool binary) {
    validate(mesh, "cannot write '" + path + "'");
    const std::size_t np = mesh.points.size(), nt = mesh.tets.size();
    if ((np > 0x7fffffffu || nt > 0x7fffffffu) && binary)
        throw Error(ErrorCode::TooLarge,
                    "'" + path + "': more than 2^31 nodes or elements (MSH data tags are int)");
    MshOut o(binary);
    o.text(binary ? "$MeshFormat\n4.1 1 8\n" : "$MeshFormat\n4.1 0 8\n");
    if (binary) {
        const int32_t one = 1;  // lets readers detect the byte order
        char b[4];
        std::memcpy(b, &one, 4);
        o.text(std::string(b, 4));
    }
    o.end("MeshFormat");

    o.text("$Nodes\n");
    o.size(np ? 1 : 0), o.size(np), o.size(np ? 1 : 0), o.size(np), o.eol();
    if (np) {
        o.integer(3), o.integer(1), o.integer(0), o.size(np), o.eol();  // dim, tag, parametric
        for (std::size_t i = 0; i < np; ++i) o.size(i + 1), o.eol();
        for (const auto& p : mesh.points) {
            const auto w = mesh.geometry.world(p);
            o.real(w[0]), o.real(w[1]), o.real(w[2]), o.eol();
        }
    }
    o.end("Nodes");

    o.text("$Elements\n");
    o.size(nt ? 1 : 0), o.size(nt), o.size(nt ? 1 : 0), o.size(nt), o.eol();
    if (nt) {
        o.integer(3), o.integer(1), o.integer(4), o.size(nt), o.eol();  // type 4: 4-node tet
        for (std::size_t i = 0; i < nt; ++i) {
            const auto& t = mesh.tets[i];
            o.size(i + 1);
            for (uint32_t v : t) o.size(uint64_t(v) + 1);
            o.eol();
        }
    }
    o.end("Elements");

    view(o, "NodeData", mesh.field_name, np, [&](std::size_t i) { return mesh.values[i]; });
    if (!mesh.level.empty())
        view(o, "ElementData", "level", nt, [&](std::size_t i) { return double(mesh.level[i]); });
    if (!mesh.error.empty())
        view(o, "ElementData", "error", nt, [&](std::size_t i) { return double(mesh.error[i]); });
    write_file_atomic(path, o.bytes().data(), o.bytes().size());
}

MeshFormat gmsh_ascii_mesh_format() {
    MeshFormat f;
    f.name = "msh";
    f.extensions = {".msh"};
    f.description = "(Gmsh 4.1)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) { write_gmsh(m, path, false); };
    return f;
}

// Only by name: a .msh file is ASCII unless binary is asked for.
MeshFormat gmsh_binary_mesh_format() {
    MeshFormat f;
    f.name = "msh-binary";
    f.description = "(Gmsh 4.1 binary)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) { write_gmsh(m, path, true); };
    return f;
}

}  // namespace tetlod
