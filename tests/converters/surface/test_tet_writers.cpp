// Gmsh MSH 4.1 (ASCII, binary) and Medit (.mesh + .sol) writers, read back by
// meshio and by gmsh itself; counts, orientation and values compared with the
// mesh that was written. Readers that are not installed are skipped with a reason.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>

#include "surface_test_util.hpp"
#include "tetlod/converters/gmsh_writer.hpp"
#include "tetlod/converters/medit_writer.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {
namespace {

namespace fs = std::filesystem;

std::string tmp(const std::string& name) { return std::string(TETLOD_TEST_TMP) + "/" + name; }

// An adaptive mesh (varied levels and errors) with non-trivial geometry.
const TetMesh& sample_mesh() {
    static const TetMesh mesh = [] {
        const HtModel model = HtModel::build(test::ball_volume(17, {8.3, 7.9, 8.1}, 6.2));
        LodQuery q;
        q.error_in = 0.5;
        q.isovalues = {0.0};
        q.error_out = 20.0;
        TetMesh m = model.extract(q);
        m.geometry.spacing = {0.5, 1.0, 2.0};
        m.geometry.origin = {-1.0, 2.0, 3.5};
        m.field_name = "density";
        return m;
    }();
    return mesh;
}

double value_sum(const TetMesh& m) { return std::accumulate(m.values.begin(), m.values.end(), 0.0); }
double level_sum(const TetMesh& m) {
    double s = 0;
    for (auto l : m.level) s += l;
    return s;
}

std::optional<nlohmann::json> meshio_read(const std::string& path) {
    const auto out = test::run("/usr/bin/python3 " TETLOD_READ_BACK_PY " meshio '" + path + "'");
    if (!out) return std::nullopt;
    return nlohmann::json::parse(*out);
}

std::string head(const std::string& path, std::size_t n) {
    std::ifstream f(path, std::ios::binary);
    std::string s(n, '\0');
    f.read(s.data(), static_cast<std::streamsize>(n));
    s.resize(static_cast<std::size_t>(f.gcount()));
    return s;
}

TEST(TetWriters, DispatcherChoosesByExtensionAndName) {
    const TetMesh& m = sample_mesh();
    write_tet_mesh(m, tmp("d.msh"));
    EXPECT_EQ(head(tmp("d.msh"), 20), "$MeshFormat\n4.1 0 8\n");
    write_tet_mesh(m, tmp("d2.msh"), "msh-binary");
    EXPECT_EQ(head(tmp("d2.msh"), 20), "$MeshFormat\n4.1 1 8\n");
    write_tet_mesh(m, tmp("d.MESH"));
    EXPECT_TRUE(fs::exists(tmp("d.sol")));
    const auto names = mesh_format_names();
    for (const char* n : {"msh", "msh-binary", "mesh", "vtu", "vtk"})
        EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
    EXPECT_THROW(write_tet_mesh(m, tmp("d.xyz")), Error);
    // Atomic writes leave nothing but the targets behind.
    for (const auto& e : fs::directory_iterator(TETLOD_TEST_TMP))
        EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(TetWriters, InconsistentMeshIsRefused) {
    TetMesh m = sample_mesh();
    m.values.pop_back();
    EXPECT_THROW(write_gmsh(m, tmp("bad.msh"), false), Error);
    EXPECT_THROW(write_medit(m, tmp("bad.mesh")), Error);
    EXPECT_FALSE(fs::exists(tmp("bad.msh")));
}

TEST(TetWriters, SolFileHoldsTheExactField) {
    const TetMesh& m = sample_mesh();
    write_medit(m, tmp("exact.mesh"));
    std::ifstream f(tmp("exact.sol"));
    std::string word;
    std::size_t n = 0;
    int dim = 0, fields = 0, type = 0;
    f >> word >> dim;  // MeshVersionFormatted 2
    f >> word >> dim;  // Dimension 3
    EXPECT_EQ(dim, 3);
    f >> word >> n >> fields >> type;
    EXPECT_EQ(word, "SolAtVertices");
    ASSERT_EQ(n, m.values.size());
    EXPECT_EQ(fields, 1);
    EXPECT_EQ(type, 1);
    for (double v : m.values) {
        double r = 0;
        f >> r;
        EXPECT_EQ(r, v);  // %.17g round-trips doubles exactly
    }
    f >> word;
    EXPECT_EQ(word, "End");
}

TEST(TetWriters, MeshioReadsEveryFormat) {
    const std::string missing = test::python_reader_missing("meshio");
    if (!missing.empty()) GTEST_SKIP() << missing;
    const TetMesh& m = sample_mesh();
    const double vmax = *std::max_element(m.error.begin(), m.error.end());
    struct Case { std::string file, format; };
    for (const Case& c : {Case{"m_ascii.msh", "msh"}, Case{"m_bin.msh", "msh-binary"},
                          Case{"m.mesh", "mesh"}}) {
        SCOPED_TRACE(c.file);
        write_tet_mesh(m, tmp(c.file), c.format);
        const auto j = meshio_read(tmp(c.file));
        ASSERT_TRUE(j) << "meshio failed to read " << c.file;
        EXPECT_EQ((*j)["points"].get<std::size_t>(), m.points.size());
        EXPECT_EQ((*j)["cells"]["tetra"].get<std::size_t>(), m.tets.size());
        EXPECT_EQ((*j)["positive_tets"].get<std::size_t>(), m.tets.size());
        const auto lo = m.geometry.world({0, 0, 0});
        const auto& b = (*j)["bounds"];
        EXPECT_DOUBLE_EQ(b[0].get<double>(), lo[0]);
        EXPECT_DOUBLE_EQ(b[5].get<double>(), m.geometry.origin[2] + 2.0 * 16);
        if (c.format == "mesh") {
            EXPECT_DOUBLE_EQ((*j)["cell_data"]["medit:ref"][0].get<double>(), level_sum(m));
        } else {
            EXPECT_NEAR((*j)["point_data"]["density"].get<double>(), value_sum(m),
                        1e-12 * std::abs(value_sum(m)) + 1e-9);
            EXPECT_DOUBLE_EQ((*j)["cell_data"]["level"][0].get<double>(), level_sum(m));
            EXPECT_DOUBLE_EQ((*j)["cell_data"]["error"][1].get<double>(), double(vmax));
        }
    }
}

TEST(TetWriters, GmshReadsMshAndMedit) {
    const std::string missing = test::gmsh_missing();
    if (!missing.empty()) GTEST_SKIP() << missing;
    const TetMesh& m = sample_mesh();
    const auto [vmin, vmax] = std::minmax_element(m.values.begin(), m.values.end());
    const auto [emin, emax] = std::minmax_element(m.error.begin(), m.error.end());
    const auto [lmin, lmax] = std::minmax_element(m.level.begin(), m.level.end());
    for (const std::string format : {"msh", "msh-binary", "mesh"}) {
        SCOPED_TRACE(format);
        const std::string file = tmp("g_" + (format == "mesh" ? std::string("m.mesh") : format + ".msh"));
        write_tet_mesh(m, file, format);
        const std::string geo = tmp("check_" + format + ".geo");
        std::ofstream(geo) << "Merge \"" << file << "\";\n"
                           << "Printf(\"tetlod %g %g %g\", Mesh.NbNodes, Mesh.NbTetrahedra, "
                              "PostProcessing.NbViews);\n"
                           << "For i In {0:PostProcessing.NbViews-1}\n"
                           << "  Printf(\"view %.17g %.17g\", View[i].Min, View[i].Max);\n"
                           << "EndFor\n";
        const auto out = test::run("cd '" + std::string(TETLOD_TEST_TMP) + "' && timeout 120 gmsh '" +
                                   geo + "' -0 -nopopup 2>&1");
        ASSERT_TRUE(out) << "gmsh failed";
        std::istringstream lines(*out);
        std::string line;
        double nodes = -1, tets = -1, views = -1;
        std::vector<std::pair<double, double>> ranges;
        while (std::getline(lines, line)) {
            std::istringstream ls(line);
            std::string w;
            ls >> w;
            if (w == "tetlod") ls >> nodes >> tets >> views;
            if (w == "view") {
                double a, b;
                ls >> a >> b;
                ranges.emplace_back(a, b);
            }
        }
        EXPECT_EQ(nodes, double(m.points.size())) << *out;
        EXPECT_EQ(tets, double(m.tets.size()));
        if (format == "mesh") continue;  // gmsh does not load .sol with Merge
        ASSERT_EQ(views, 3.0);
        ASSERT_EQ(ranges.size(), 3u);
        EXPECT_EQ(ranges[0].first, *vmin);
        EXPECT_EQ(ranges[0].second, *vmax);
        EXPECT_EQ(ranges[1].first, double(*lmin));
        EXPECT_EQ(ranges[1].second, double(*lmax));
        EXPECT_EQ(ranges[2].first, double(*emin));
        EXPECT_EQ(ranges[2].second, double(*emax));
    }
}

}  // namespace
}  // namespace tetlod
