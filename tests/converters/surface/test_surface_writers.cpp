// Surface writers (PLY binary/ASCII, OBJ, OFF, STL binary/ASCII) read back with
// OpenMesh (C++), meshio and VTK; counts, positions, normals and the per-face
// error compared with the isosurface that was written.
#include <gtest/gtest.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "surface_test_util.hpp"
#include "tetlod/codec/isosurface.hpp"
#include "tetlod/converters/surface_writer.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {
namespace {

namespace fs = std::filesystem;
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

std::string tmp(const std::string& name) { return std::string(TETLOD_TEST_TMP) + "/" + name; }

const TriangleMesh& sphere() {
    static const TriangleMesh s = [] {
        TetMesh m = test::full_mesh(test::ball_volume(17, {8.3, 7.9, 8.1}, 6.2));
        m.error.assign(m.tets.size(), 0.0f);
        for (std::size_t i = 0; i < m.tets.size(); ++i) m.error[i] = float(i % 7) * 0.25f;
        m.geometry.spacing = {1.0, 2.0, 0.5};
        const double iso[] = {0.0, 20.0};
        return marching_tetrahedra(m, iso);
    }();
    return s;
}

struct Case {
    std::string file;
    bool binary;
};
const std::vector<Case> kCases = {{"s_bin.ply", true}, {"s_ascii.ply", false}, {"s.obj", false},
                                  {"s.off", false},     {"s_bin.stl", true},   {"s_ascii.stl", false}};

void write_all() {
    for (const auto& c : kCases) {
        SurfaceWriteOptions o;
        o.binary = c.binary;
        write_surface(sphere(), tmp(c.file), "", o);
    }
}

TEST(SurfaceWriters, OpenMeshReadsEveryFormat) {
    write_all();
    const TriangleMesh& s = sphere();
    for (const auto& c : kCases) {
        SCOPED_TRACE(c.file);
        OmMesh m;
        m.request_vertex_normals();
        OpenMesh::IO::Options opt = OpenMesh::IO::Options::VertexNormal;
        if (c.binary) opt += OpenMesh::IO::Options::Binary;
        ASSERT_TRUE(OpenMesh::IO::read_mesh(m, tmp(c.file), opt));
        EXPECT_EQ(m.n_faces(), s.faces.size());
        const bool stl = c.file.ends_with(".stl");
        if (stl) {
            // STL stores triangle soup; OpenMesh merges equal positions, so it
            // finds at most our vertex count.
            EXPECT_LE(m.n_vertices(), s.points.size());
            continue;
        }
        ASSERT_EQ(m.n_vertices(), s.points.size());
        for (std::size_t i = 0; i < s.points.size(); i += 37) {
            const auto p = m.point(OmMesh::VertexHandle(int(i)));
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(p[k], s.points[i][k], 1e-5 * (1 + std::abs(s.points[i][k])));
            if (opt.check(OpenMesh::IO::Options::VertexNormal)) {
                const auto n = m.normal(OmMesh::VertexHandle(int(i)));
                for (int k = 0; k < 3; ++k) EXPECT_NEAR(n[k], s.normals[i][k], 1e-5);
            }
        }
        // Same faces in the same order (ids and winding).
        for (std::size_t f = 0; f < s.faces.size(); f += 53) {
            std::vector<uint32_t> ids;
            for (auto v : m.fv_range(OmMesh::FaceHandle(int(f)))) ids.push_back(uint32_t(v.idx()));
            ASSERT_EQ(ids.size(), 3u);
            // OpenMesh may start the cycle at another vertex: compare rotations.
            const auto& t = s.faces[f];
            const bool same = (ids[0] == t[0] && ids[1] == t[1] && ids[2] == t[2]) ||
                              (ids[0] == t[1] && ids[1] == t[2] && ids[2] == t[0]) ||
                              (ids[0] == t[2] && ids[1] == t[0] && ids[2] == t[1]);
            EXPECT_TRUE(same) << "face " << f;
        }
    }
}

TEST(SurfaceWriters, PlyCarriesTheFaceErrorForOpenMesh) {
    write_all();
    const TriangleMesh& s = sphere();
    for (const char* file : {"s_ascii.ply", "s_bin.ply"}) {
        SCOPED_TRACE(file);
        OmMesh m;
        OpenMesh::IO::Options opt = OpenMesh::IO::Options::Custom;
        if (std::string(file).find("bin") != std::string::npos) opt += OpenMesh::IO::Options::Binary;
        ASSERT_TRUE(OpenMesh::IO::read_mesh(m, tmp(file), opt));
        OpenMesh::FPropHandleT<float> err;
        if (!m.get_property_handle(err, "error")) {
            // OpenMesh 9 reads custom PLY properties only from ASCII files.
            EXPECT_NE(std::string(file), "s_ascii.ply") << "no error property read back";
            continue;
        }
        for (std::size_t f = 0; f < s.faces.size(); ++f)
            ASSERT_EQ(m.property(err, OmMesh::FaceHandle(int(f))), s.face_error[f]);
    }
}

TEST(SurfaceWriters, MeshioAndVtkReadEveryFormat) {
    write_all();
    const TriangleMesh& s = sphere();
    double err_sum = 0, err_max = 0;
    for (float e : s.face_error) err_sum += e, err_max = std::max(err_max, double(e));
    for (const std::string lib : {"meshio", "vtk"}) {
        const std::string missing = test::python_reader_missing(lib);
        if (!missing.empty()) {
            std::printf("[  SKIP    ] %s: %s\n", lib.c_str(), missing.c_str());
            continue;
        }
        for (const auto& c : kCases) {
            if (lib == "vtk" && c.file.ends_with(".off")) continue;  // VTK has no OFF reader
            if (lib == "meshio" && c.file == "s_bin.ply") {
                // meshio 5.0 reads binary PLY face elements column by column, which is
                // wrong as soon as a face has a property besides its vertex list
                // (IndexError in _read_binary_list); OpenMesh and VTK read the file.
                std::printf("[  SKIP    ] meshio on %s: meshio 5 cannot read binary PLY faces "
                            "with extra properties\n", c.file.c_str());
                continue;
            }
            SCOPED_TRACE(lib + " " + c.file);
            const auto out = test::run("/usr/bin/python3 " TETLOD_READ_BACK_PY " " + lib + " '" +
                                       tmp(c.file) + "'");
            ASSERT_TRUE(out) << lib << " failed to read " << c.file;
            const auto j = nlohmann::json::parse(*out);
            EXPECT_EQ(j["cells"]["triangle"].get<std::size_t>(), s.faces.size());
            if (!c.file.ends_with(".stl")) {
                EXPECT_EQ(j["points"].get<std::size_t>(), s.points.size());
            }
            if (c.file.ends_with(".ply") && lib == "meshio") {
                ASSERT_TRUE(j["cell_data"].contains("error")) << *out;
                EXPECT_NEAR(j["cell_data"]["error"][0].get<double>(), err_sum, 1e-6 * err_sum);
                EXPECT_EQ(j["cell_data"]["error"][1].get<double>(), err_max);
            }
        }
    }
}

TEST(SurfaceWriters, RefusesBadInputAndLeavesNoTemporaries) {
    TriangleMesh s = sphere();
    EXPECT_THROW(write_surface(s, tmp("x.xyz")), Error);
    s.faces.push_back({0, 1, uint32_t(s.points.size())});
    EXPECT_THROW(write_surface(s, tmp("bad.ply")), Error);
    EXPECT_FALSE(fs::exists(tmp("bad.ply")));
    for (const auto& e : fs::directory_iterator(TETLOD_TEST_TMP))
        EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

}  // namespace
}  // namespace tetlod
