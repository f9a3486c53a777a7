// The mesh-output and inspection commands as a user runs them: isosurface,
// extract to Gmsh/Medit, stats and compare. Files are read back with meshio and
// VTK when /usr/bin/python3 has them (skipped with a reason otherwise).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "cli_runner.hpp"

namespace fs = std::filesystem;

namespace {

using namespace tetlod_cli_test;
using CliResult = CliRun;
inline CliRun cli(const std::string& args) { return run(args); }


bool python_has(const std::string& lib) {
    return std::system(("/usr/bin/python3 -c 'import " + lib + "' >/dev/null 2>&1").c_str()) == 0;
}

// A 21^3 u8 ball (values fall off from the centre), named so the raw reader
// takes dims and type from the name.
const std::string& ball_raw() {
    static const std::string path = [] {
        const std::string p = tmp("ball_21x21x21_uint8.raw");
        std::ofstream f(p, std::ios::binary);
        for (int z = 0; z < 21; ++z)
            for (int y = 0; y < 21; ++y)
                for (int x = 0; x < 21; ++x) {
                    const double d = std::sqrt((x - 10.2) * (x - 10.2) + (y - 9.8) * (y - 9.8) + (z - 10.1) * (z - 10.1));
                    f.put(char(static_cast<unsigned char>(std::lround(std::max(0.0, 250.0 - 20.0 * d)))));
                }
        return p;
    }();
    return path;
}

long number_after(const std::string& text, const std::string& key) {
    std::smatch m;
    if (!std::regex_search(text, m, std::regex(key + R"(\s+(\d+))"))) return -1;
    return std::stol(m[1]);
}

TEST(CliMeshOutputs, IsosurfaceWritesEveryFormatAndReportsCounts) {
    long ply_faces = -1;
    for (const char* out : {"iso.ply", "iso.obj", "iso.off", "iso.stl"}) {
        SCOPED_TRACE(out);
        const CliResult r = cli("isosurface '" + ball_raw() + "' '" + tmp(out) + "' --isovalue 120");
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_TRUE(fs::exists(tmp(out)));
        const long faces = number_after(r.out, "surface");
        EXPECT_GT(faces, 100) << r.out;
        if (std::string(out) == "iso.ply") ply_faces = faces;
        if (python_has("meshio")) {
            const CliResult m = sh("/usr/bin/python3 -c \"import meshio; m = meshio.read('" + tmp(out) +
                             "'); print(sum(len(c.data) for c in m.cells))\"");
            ASSERT_EQ(m.code, 0) << m.err;  // the default binary PLY included
            EXPECT_EQ(std::stol(m.out), faces);
        } else {
            std::printf("[  SKIP    ] meshio: /usr/bin/python3 cannot import meshio\n");
        }
    }
    // The default binary PLY also loads in gmsh, with every triangle.
    if (sh("command -v gmsh").code == 0) {
        const CliResult g = sh("gmsh -check '" + tmp("iso.ply") + "' 2>&1");
        EXPECT_EQ(g.code, 0) << g.out;
        EXPECT_EQ(g.out.find("Error"), std::string::npos) << g.out;
        EXPECT_NE(g.out.find(" " + std::to_string(ply_faces) + " triangles"), std::string::npos) << g.out;
    } else {
        std::printf("[  SKIP    ] gmsh is not installed (apt-get install gmsh)\n");
    }
    const CliResult ascii = cli("isosurface '" + ball_raw() + "' '" + tmp("iso_a.ply") + "' --isovalue 120 --ascii");
    ASSERT_EQ(ascii.code, 0) << ascii.err;
    EXPECT_NE(slurp(tmp("iso_a.ply")).find("format ascii 1.0"), std::string::npos);
    EXPECT_EQ(slurp(tmp("iso_a.ply")).find("property float error"), std::string::npos);  // plain by default
    const CliResult extras = cli("isosurface '" + ball_raw() + "' '" + tmp("iso_x.ply") +
                                 "' --isovalue 120 --ascii --ply-extras");
    ASSERT_EQ(extras.code, 0) << extras.err;
    const std::string header = slurp(tmp("iso_x.ply")).substr(0, 400);
    EXPECT_NE(header.find("property float nx"), std::string::npos) << header;
    EXPECT_NE(header.find("property float error"), std::string::npos) << header;
    EXPECT_NE(header.find("property int surface"), std::string::npos) << header;
}

TEST(CliMeshOutputs, IsosurfaceOnTlodAndWithTheMt) {
    ASSERT_EQ(cli("convert '" + ball_raw() + "' '" + tmp("ball.tlod") + "'").code, 0);
    const CliResult from_volume = cli("isosurface '" + ball_raw() + "' '" + tmp("v.ply") + "' --isovalue 120");
    const CliResult from_tlod = cli("isosurface '" + tmp("ball.tlod") + "' '" + tmp("t.ply") + "' --isovalue 120");
    ASSERT_EQ(from_tlod.code, 0) << from_tlod.err;
    // Same model, same query: the same surface.
    EXPECT_EQ(number_after(from_tlod.out, "surface"), number_after(from_volume.out, "surface"));
    const CliResult mt = cli("isosurface '" + ball_raw() + "' '" + tmp("m.ply") + "' --isovalue 120 --model mt");
    ASSERT_EQ(mt.code, 0) << mt.err;
    EXPECT_GT(number_after(mt.out, "surface"), 100);
    const CliResult refused = cli("isosurface '" + tmp("ball.tlod") + "' '" + tmp("x.ply") + "' --isovalue 120 --model mt");
    EXPECT_NE(refused.code, 0);
    EXPECT_NE(refused.err.find("ball.tlod"), std::string::npos) << refused.err;  // names the file
    EXPECT_FALSE(fs::exists(tmp("x.ply")));
    EXPECT_NE(cli("isosurface '" + ball_raw() + "' '" + tmp("y.ply") + "'").code, 0);  // no isovalue
}

TEST(CliMeshOutputs, ExtractWritesGmshAndMedit) {
    for (const std::string& args : {std::string("e.msh"), std::string("eb.msh --format msh-binary"),
                                    std::string("e.mesh")}) {
        SCOPED_TRACE(args);
        const CliResult r = cli("extract '" + ball_raw() + "' " + tmp(args) + " --error 2%");
        ASSERT_EQ(r.code, 0) << r.err;
        const long tets = number_after(r.out, "mesh");
        if (!python_has("meshio")) continue;
        const std::string file = tmp(args.substr(0, args.find(' ')));
        const CliResult m = sh("/usr/bin/python3 -c \"import meshio; m = meshio.read('" + file +
                         "'); print(sum(len(c.data) for c in m.cells if c.type == 'tetra'))\"");
        ASSERT_EQ(m.code, 0) << m.err;
        EXPECT_EQ(std::stol(m.out), tets);
    }
    EXPECT_TRUE(fs::exists(tmp("e.sol")));
}

TEST(CliMeshOutputs, StatsJsonIsConsistent) {
    const CliResult r = cli("stats '" + ball_raw() + "' --json");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j["models"].size(), 2u);
    for (const auto& m : j["models"]) {
        SCOPED_TRACE(m["model"].get<std::string>());
        const auto& u = m["uniform"];
        ASSERT_EQ(u.size(), 9u);
        for (std::size_t i = 1; i < u.size(); ++i)
            EXPECT_LE(u[i]["tets"].get<double>(), u[i - 1]["tets"].get<double>());  // coarser with error
        EXPECT_LE(u[0]["tets"].get<double>(), m["full"]["tets"].get<double>());
        for (std::size_t i = 0; i < u.size(); ++i) {
            EXPECT_LE(m["box"][i]["tets"].get<double>(), m["full"]["tets"].get<double>());
            EXPECT_GT(m["isovalue"][i]["isosurface_faces"].get<double>(), 0.0);
        }
        const auto& q = m["shape_quality_lod"];
        EXPECT_LE(q["min"].get<double>(), q["mean"].get<double>());
        EXPECT_LE(q["mean"].get<double>(), q["max"].get<double>());
        if (m["model"] == "HT") {  // three shapes: ratios exactly 0.866 and 1.118
            EXPECT_NEAR(q["min"].get<double>(), std::sqrt(3.0) / 2, 1e-9);
            EXPECT_LE(q["max"].get<double>(), std::sqrt(5.0) / 2 + 1e-9);
        } else {
            EXPECT_GT(m["tets_per_split"].get<double>(), 0.0);
        }
    }
}

TEST(CliMeshOutputs, StatsOnTlodCountsFileBytesAndPlots) {
    ASSERT_EQ(cli("convert '" + ball_raw() + "' '" + tmp("s.tlod") + "'").code, 0);
    const CliResult r = cli("stats '" + tmp("s.tlod") + "' --json --plot '" + tmp("plots") + "'");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j["models"].size(), 1u);
    EXPECT_EQ(j["models"][0]["stored_bytes"].get<uint64_t>(), fs::file_size(tmp("s.tlod")));
    EXPECT_NEAR(j["models"][0]["stored_bytes_per_point"].get<double>(),
                double(fs::file_size(tmp("s.tlod"))) / (21.0 * 21 * 21), 1e-9);
    for (const char* f : {"uniform_tets.svg", "box_tets.svg", "isovalue_tets.svg", "shape_quality.svg",
                          "extract_time.svg", "stats.csv", "shape_quality.csv"})
        EXPECT_TRUE(fs::exists(tmp(std::string("plots/") + f))) << f;
    if (python_has("xml")) {  // every SVG is well-formed XML
        const CliResult x = sh("/usr/bin/python3 -c \"import glob, xml.etree.ElementTree as E; "
                         "[E.parse(f) for f in glob.glob('" + tmp("plots") + "/*.svg')]\"");
        EXPECT_EQ(x.code, 0) << x.err;
    }
    EXPECT_NE(cli("stats '" + tmp("s.tlod") + "' --model mt").code, 0);
}

TEST(CliMeshOutputs, CompareWritesAReportWithItsPlots) {
    const CliResult r = cli("compare '" + ball_raw() + "' --report '" + tmp("report") + "'");
    ASSERT_EQ(r.code, 0) << r.err;
    const std::string md = slurp(tmp("report/report.md"));
    for (const char* s : {"stored bytes per grid point", "HT (paper)", "MT (tetlod)", "tets added per vertex split"})
        EXPECT_NE(md.find(s), std::string::npos) << s;
    // Every image the report links exists.
    const std::regex img(R"(!\[[^\]]*\]\(([^)]+)\))");
    int images = 0;
    for (auto it = std::sregex_iterator(md.begin(), md.end(), img); it != std::sregex_iterator(); ++it, ++images)
        EXPECT_TRUE(fs::exists(tmp("report/" + (*it)[1].str()))) << (*it)[1];
    EXPECT_EQ(images, 5);
    const auto j = nlohmann::json::parse(slurp(tmp("report/stats.json")));
    EXPECT_EQ(j["models"].size(), 2u);
}

TEST(CliMeshOutputs, CompareOnAContainerMeasuresItsStoredModels) {
    ASSERT_EQ(cli("convert '" + ball_raw() + "' '" + tmp("both.tlod") + "' --model ht,mt").code, 0);
    ASSERT_EQ(cli("convert '" + ball_raw() + "' '" + tmp("ht.tlod") + "'").code, 0);
    ASSERT_EQ(cli("convert '" + ball_raw() + "' '" + tmp("mt.tlod") + "' --model mt").code, 0);
    CliResult r = cli("compare '" + tmp("both.tlod") + "' --report '" + tmp("report_both") + "'");
    ASSERT_EQ(r.code, 0) << r.err;
    auto j = nlohmann::json::parse(slurp(tmp("report_both/stats.json")));
    ASSERT_EQ(j["models"].size(), 2u);
    r = cli("compare '" + tmp("ht.tlod") + "' --report '" + tmp("report_ht") + "'");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(slurp(tmp("report_ht/report.md")).find("not in the container"), std::string::npos);
    EXPECT_EQ(nlohmann::json::parse(slurp(tmp("report_ht/stats.json")))["models"].size(), 1u);
    r = cli("compare '" + tmp("mt.tlod") + "' --report '" + tmp("report_mt") + "'");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("holds no HT"), std::string::npos) << r.err;
}

}  // namespace
