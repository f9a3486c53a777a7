// Surface writers through OpenMesh's IO (OpenMesh 9: IOManager writers for PLY,
// OBJ, OFF, STL). OpenMesh 9's PLY writer does write custom properties: every
// face property marked persistent goes into the header as "property <type>
// <name>" (checked against its output), so the per-face error and surface index
// need no PLY code of our own. OpenMesh writes to a stream, which we hand to
// AtomicFile so a failed or interrupted write never leaves a partial file.
#include "tetlod/converters/surface_writer.hpp"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <sstream>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

struct Traits : OpenMesh::DefaultTraits {
    using Point = OpenMesh::Vec3d;
    using Normal = OpenMesh::Vec3d;
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<Traits>;

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

std::string joined() {
    std::string r;
    for (const auto& f : surface_format_names()) r += (r.empty() ? "" : ", ") + f;
    return r;
}

void check(const TriangleMesh& s, const std::string& path) {
    auto bad = [&](const std::string& what) {
        throw Error(ErrorCode::InvalidArgument, "'" + path + "': " + what);
    };
    const std::size_t n = s.points.size();
    if (!s.normals.empty() && s.normals.size() != n) bad("normals do not match the points");
    if (!s.face_error.empty() && s.face_error.size() != s.faces.size())
        bad("face errors do not match the faces");
    if (!s.face_surface.empty() && s.face_surface.size() != s.faces.size())
        bad("face surface ids do not match the faces");
    for (const auto& f : s.faces)
        for (uint32_t v : f)
            if (v >= n) bad("a face refers to vertex " + std::to_string(v) + " of " + std::to_string(n));
}

// OpenMesh 9's ASCII STL has an empty line before each "endloop" and an unnamed
// "solid ". Both are legal, but line-based readers (meshio 5) fail on the empty
// lines, so we drop them and name the solid.
std::string tidy_ascii_stl(const std::string& in) {
    std::string out;
    out.reserve(in.size());
    std::size_t pos = 0;
    bool first = true;
    while (pos < in.size()) {
        std::size_t nl = in.find('\n', pos);
        if (nl == std::string::npos) nl = in.size();
        std::string line = in.substr(pos, nl - pos);
        pos = nl + 1;
        if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
        if (first && line.rfind("solid", 0) == 0 && line.find_first_not_of(" ", 5) == std::string::npos)
            line = "solid tetlod";
        if (line == "endsolid " || line == "endsolid") line = "endsolid tetlod";
        first = false;
        out += line;
        out += '\n';
    }
    return out;
}

}  // namespace

std::vector<std::string> surface_format_names() { return {"ply", "obj", "off", "stl"}; }

void write_surface(const TriangleMesh& s, const std::string& path, const std::string& format,
                   const SurfaceWriteOptions& options) {
    std::string f = lower(format);
    if (f.empty()) {
        f = lower(std::filesystem::path(path).extension().string());
        if (!f.empty() && f[0] == '.') f.erase(0, 1);
    }
    const auto names = surface_format_names();
    if (std::find(names.begin(), names.end(), f) == names.end())
        throw Error(ErrorCode::InvalidArgument,
                    "'" + path + "': unknown surface format '" + f + "' (supported: " + joined() + ")");
    check(s, path);

    OmMesh m;
    // OFF stays plain "OFF": the NOFF variant with normals is refused by common
    // readers (meshio 5 among them), and OFF is chosen for compatibility.
    const bool normals = options.normals && !s.normals.empty() && f != "stl" && f != "off" &&
                         (f != "ply" || options.ply_extras);
    if (normals) m.request_vertex_normals();
    m.request_face_normals();
    std::vector<OmMesh::VertexHandle> vh;
    vh.reserve(s.points.size());
    for (std::size_t i = 0; i < s.points.size(); ++i) {
        const auto& p = s.points[i];
        vh.push_back(m.add_vertex(OmMesh::Point(p[0], p[1], p[2])));
        if (normals) {
            const auto& q = s.normals[i];
            m.set_normal(vh.back(), OmMesh::Normal(q[0], q[1], q[2]));
        }
    }
    OpenMesh::FPropHandleT<float> error_prop;
    OpenMesh::FPropHandleT<int> surface_prop;
    const bool props = f == "ply" && options.ply_extras;
    if (props) {
        m.add_property(error_prop, "error");
        m.property(error_prop).set_persistent(true);
        m.add_property(surface_prop, "surface");
        m.property(surface_prop).set_persistent(true);
    }
    // OpenMesh's half-edge structure refuses faces that would make an edge or a
    // vertex non-manifold. Marching-tets surfaces are manifold, but a caller's
    // mesh may not be: such a face is written with its own copies of its
    // vertices rather than dropped, so geometry is never lost.
    for (std::size_t i = 0; i < s.faces.size(); ++i) {
        const auto& t = s.faces[i];
        auto fh = m.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
        if (!fh.is_valid()) {
            OmMesh::VertexHandle c[3];
            for (int k = 0; k < 3; ++k) {
                c[k] = m.add_vertex(m.point(vh[t[k]]));
                if (normals) m.set_normal(c[k], m.normal(vh[t[k]]));
            }
            fh = m.add_face(c[0], c[1], c[2]);
        }
        if (props) {
            m.property(error_prop, fh) = s.face_error.empty() ? 0.0f : s.face_error[i];
            m.property(surface_prop, fh) = s.face_surface.empty() ? 0 : s.face_surface[i];
        }
    }
    m.update_face_normals();

    OpenMesh::IO::Options opt = OpenMesh::IO::Options::Default;
    if (normals) opt += OpenMesh::IO::Options::VertexNormal;
    if (f == "stl") opt += OpenMesh::IO::Options::FaceNormal;
    if (props) opt += OpenMesh::IO::Options::Custom;
    if (options.binary && (f == "ply" || f == "stl")) opt += OpenMesh::IO::Options::Binary;
    omlog().disable();  // OpenMesh logs every write to stderr
    std::ostringstream os(std::ios::out | std::ios::binary);
    if (!OpenMesh::IO::write_mesh(m, os, "." + f, opt, 9))
        throw Error(ErrorCode::IoError, "'" + path + "': OpenMesh could not write the " + f + " data");
    std::string bytes = os.str();
    if (f == "stl" && !options.binary) bytes = tidy_ascii_stl(bytes);
    write_file_atomic(path, bytes.data(), bytes.size());
}

}  // namespace tetlod
