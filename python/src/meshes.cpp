// tetlod.Mesh (a tetrahedral mesh) and tetlod.Surface (a triangle surface): the
// C++ meshes moved into Python objects, their arrays exposed as read-only numpy
// views that keep the object alive (no copies), and the writers.
#include <string>

#include "bindings.hpp"
#include "common.hpp"
#include "tetlod/converters/features.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/triangle_mesh.hpp"
#if TETLOD_HAVE_OPENMESH
#include "tetlod/converters/surface_writer.hpp"
#endif

namespace py = pybind11;

namespace tetlod::python {
namespace {

// compress: True (the default compressor, zlib), False (none), or a name:
// "lz4", "zlib", "lzma", "none".
void write_mesh(const TetMesh& mesh, const std::string& path, const std::string& format,
                const py::object& compress) {
    MeshWriteOptions options;
    if (py::isinstance<py::bool_>(compress)) {
        if (!compress.cast<bool>()) options.compression = MeshCompression::None;
    } else {
        const std::string name = py::str(compress);
        const auto c = parse_mesh_compression(name);
        if (!c) throw Error(ErrorCode::InvalidArgument, "compress='" + name + "': expected lz4, zlib, lzma or none");
        options.compression = *c;
    }
    py::gil_scoped_release release;
    write_tet_mesh(mesh, path, format, options);
}

void write_surface_file(const TriangleMesh& surface, const std::string& path) {
#if TETLOD_HAVE_OPENMESH
    py::gil_scoped_release release;
    write_surface(surface, path);
#else
    (void)surface;
    throw Error(ErrorCode::NotBuilt, path + ": surface writers not built (TETLOD_WITH_OPENMESH=OFF)");
#endif
}

void bind_mesh(py::module_& m) {
    py::class_<TetMesh>(m, "Mesh", py::dynamic_attr(),
                        "A tetrahedral mesh. Arrays are read-only views into the mesh (no copies).")
        .def_property_readonly(
            "points",
            [](py::object self) {
                const auto& mesh = self.cast<const TetMesh&>();
                return view(self, reinterpret_cast<const int32_t*>(mesh.points.data()),
                            mesh.points.size(), 3);
            },
            "Vertices as grid index coordinates, int32 (N, 3); world_points() maps them.")
        .def_property_readonly(
            "tets",
            [](py::object self) {
                const auto& mesh = self.cast<const TetMesh&>();
                return view(self, reinterpret_cast<const uint32_t*>(mesh.tets.data()),
                            mesh.tets.size(), 4);
            },
            "Vertex ids of each tet, uint32 (M, 4), positively oriented.")
        .def_property_readonly(
            "values",
            [](py::object self) {
                const auto& mesh = self.cast<const TetMesh&>();
                return view(self, mesh.values.data(), mesh.values.size());
            },
            "Field value at each vertex, float64 (N,): exact samples of the volume.")
        .def_property_readonly(
            "error",
            [](py::object self) {
                const auto& mesh = self.cast<const TetMesh&>();
                return view(self, mesh.error.data(), mesh.error.size());
            },
            "Per tet: the error bound the query judged it by (field units), float32 (M,).")
        .def_property_readonly(
            "level",
            [](py::object self) {
                const auto& mesh = self.cast<const TetMesh&>();
                return view(self, mesh.level.data(), mesh.level.size());
            },
            "Per tet: refinement level in its model (0 = coarsest), uint8 (M,).")
        .def(
            "world_points",
            [](const TetMesh& mesh) {
                py::array_t<double> out({py::ssize_t(mesh.points.size()), py::ssize_t(3)});
                auto w = out.mutable_unchecked<2>();
                for (std::size_t i = 0; i < mesh.points.size(); ++i) {
                    const auto p = mesh.geometry.world(mesh.points[i]);
                    for (int a = 0; a < 3; ++a) w(py::ssize_t(i), a) = p[a];
                }
                return out;
            },
            "Vertices in world coordinates (origin + spacing * index), a new float64 (N, 3) array.")
        .def_property_readonly("spacing", [](const TetMesh& m) { return m.geometry.spacing; })
        .def_property_readonly("origin", [](const TetMesh& m) { return m.geometry.origin; })
        .def_readonly("field_name", &TetMesh::field_name)
        .def_property_readonly("tet_count", &TetMesh::tet_count)
        .def_property_readonly("vertex_count", &TetMesh::vertex_count)
        .def("write", &write_mesh, py::arg("path"), py::arg("format") = "", py::arg("compress") = true,
             "Writes the mesh (.vtu, .vtk, .msh, .mesh; format overrides the extension); compress: "
             "True (zlib), False, or 'zlib', 'lz4', 'lzma', 'none' (.vtu).")
        .def("__repr__", [](const TetMesh& m) {
            return "<tetlod.Mesh " + std::to_string(m.tet_count()) + " tets, " +
                   std::to_string(m.vertex_count()) + " vertices>";
        });
}

void bind_surface(py::module_& m) {
    py::class_<TriangleMesh>(m, "Surface", py::dynamic_attr(),
                             "A triangle surface in world coordinates (read-only numpy views).")
        .def_property_readonly(
            "points",
            [](py::object self) {
                const auto& s = self.cast<const TriangleMesh&>();
                return view(self, reinterpret_cast<const double*>(s.points.data()), s.points.size(), 3);
            },
            "Vertex positions, world coordinates, float64 (N, 3).")
        .def_property_readonly(
            "triangles",
            [](py::object self) {
                const auto& s = self.cast<const TriangleMesh&>();
                return view(self, reinterpret_cast<const uint32_t*>(s.faces.data()), s.faces.size(), 3);
            },
            "Vertex ids of each triangle, uint32 (M, 3).")
        .def_property_readonly(
            "normals",
            [](py::object self) {
                const auto& s = self.cast<const TriangleMesh&>();
                return view(self, reinterpret_cast<const double*>(s.normals.data()), s.normals.size(), 3);
            },
            "Unit normal per vertex (towards decreasing field), float64 (N, 3) or empty.")
        .def_property_readonly(
            "face_error",
            [](py::object self) {
                const auto& s = self.cast<const TriangleMesh&>();
                return view(self, s.face_error.data(), s.face_error.size());
            },
            "Per triangle: error bound of the tet it was cut from, float32 (M,).")
        .def_property_readonly(
            "face_surface",
            [](py::object self) {
                const auto& s = self.cast<const TriangleMesh&>();
                return view(self, s.face_surface.data(), s.face_surface.size());
            },
            "Per triangle: index of its isovalue, uint16 (M,).")
        .def("write", &write_surface_file, py::arg("path"),
             "Writes the surface (.ply, .obj, .off, .stl; needs OpenMesh in the build).")
        .def("__repr__", [](const TriangleMesh& s) {
            return "<tetlod.Surface " + std::to_string(s.face_count()) + " triangles, " +
                   std::to_string(s.vertex_count()) + " vertices>";
        });
}

}  // namespace

void bind_meshes(py::module_& m) {
    bind_mesh(m);
    bind_surface(m);
    m.def("write_mesh", &write_mesh, py::arg("mesh"), py::arg("path"), py::arg("format") = "",
          py::arg("compress") = true,
          "Writes a Mesh to any supported format (.vtu, .vtk, .msh, .mesh or format=...).");
    m.def("mesh_formats", &mesh_format_names, "Names of the tetrahedral mesh formats.");
}

}  // namespace tetlod::python
