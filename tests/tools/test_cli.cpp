// The command line as a user meets it: exit codes, what goes to stdout and
// stderr, and that failures leave no output files behind.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <vector>

#include "cli_runner.hpp"

namespace fs = std::filesystem;

namespace {

using namespace tetlod_cli_test;


bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

}  // namespace

TEST(Cli, HelpGoesToStdout) {
    const CliRun r = run("--help");
    EXPECT_EQ(r.code, 0);
    for (const char* c : {"sample", "extract", "demo"}) EXPECT_TRUE(contains(r.out, c)) << r.out;
    EXPECT_EQ(r.err, "");
    // The commands are listed in registry order.
    EXPECT_LT(r.out.find("sample"), r.out.find("extract"));

    const CliRun sub = run("extract --help");
    EXPECT_EQ(sub.code, 0);
    EXPECT_TRUE(contains(sub.out, "--error-out")) << sub.out;
    EXPECT_TRUE(contains(sub.out, "Examples")) << sub.out;
}

TEST(Cli, Version) {
    const CliRun r = run("--version");
    EXPECT_EQ(r.code, 0);
    EXPECT_TRUE(contains(r.out, "tetlod ")) << r.out;
}

TEST(Cli, SampleWritesVolumeAndHowToReadIt) {
    const std::string path = tmp("ml.raw");
    const CliRun r = run("sample marschner-lobb '" + path + "' --size 9 --dtype u16");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(fs::file_size(path), 9u * 9 * 9 * 2);
    EXPECT_TRUE(contains(r.out, "--dims 9,9,9 --dtype u16")) << r.out;
    EXPECT_EQ(r.err, "");

    const CliRun q = run("-q sample sphere '" + tmp("s.raw") + "' --dims 4,5,6");
    EXPECT_EQ(q.code, 0) << q.err;
    EXPECT_EQ(q.out, "");  // -q: results suppressed
    EXPECT_EQ(fs::file_size(tmp("s.raw")), 120u);
}

TEST(Cli, BadUsageExitsTwoWithMessageOnStderr) {
    for (const std::string args :
         {"sample sphere x.raw --bogus", "sample teapot x.raw", "sample sphere x.raw --dims 4,1,4",
          "sample sphere x.raw --size 1", "sample sphere", "frobnicate", "",
          "extract a.raw b.vtu --error abc", "extract a.raw b.vtu --box 1,2,3 --error 1",
          "extract a.raw b.vtu --dtype u7 --error 1"}) {
        SCOPED_TRACE(args);
        const CliRun r = run(args);
        EXPECT_EQ(r.code, 2);
        EXPECT_TRUE(contains(r.err, "tetlod: error:")) << r.err;
        EXPECT_EQ(r.out, "");
    }
    EXPECT_TRUE(contains(run("frobnicate").err, "frobnicate"));
    EXPECT_TRUE(contains(run("sample sphere x.raw --bogus").err, "--bogus"));
}

TEST(Cli, MissingFileIsAClearError) {
    const std::string path = tmp("absent_8x8x8_uint8.raw");
    const CliRun r = run("extract '" + path + "' '" + tmp("o.vtu") + "' --error 1");
    EXPECT_EQ(r.code, 3);
    EXPECT_TRUE(contains(r.err, "tetlod: error: cannot open '" + path + "'")) << r.err;
    EXPECT_FALSE(fs::exists(tmp("o.vtu")));
}

TEST(Cli, SizeMismatchIsAClearErrorAndWritesNothing) {
    const std::string path = tmp("short_8x8x8_uint8.raw");
    {
        std::ofstream f(path, std::ios::binary);
        f << std::string(500, 'x');
    }
    const std::string out = tmp("never.vtu");
    const CliRun r = run("extract '" + path + "' '" + out + "' --error 1");
    EXPECT_EQ(r.code, 4);
    EXPECT_TRUE(contains(r.err, "short_8x8x8_uint8.raw")) << r.err;
    EXPECT_TRUE(contains(r.err, "512")) << r.err;
    EXPECT_TRUE(contains(r.err, "500")) << r.err;
    EXPECT_FALSE(fs::exists(out));
    for (const auto& e : fs::directory_iterator(TETLOD_TEST_TMP))
        EXPECT_FALSE(contains(e.path().filename().string(), "never")) << e.path();
}

TEST(Cli, ExtractNeedsErrorOrFull) {
    ASSERT_EQ(run("-q sample sphere '" + tmp("sp_9x9x9_uint8.raw") + "' --size 9").code, 0);
    const CliRun r = run("extract '" + tmp("sp_9x9x9_uint8.raw") + "' '" + tmp("x.vtu") + "'");
    EXPECT_EQ(r.code, 2);
    EXPECT_TRUE(contains(r.err, "--full")) << r.err;
    const CliRun mt = run("extract '" + tmp("sp_9x9x9_uint8.raw") + "' '" + tmp("x.vtu") +
                          "' --error 1 --model mt --pad");  // the MT has no padding
    EXPECT_NE(mt.code, 0);
    EXPECT_TRUE(contains(mt.err, "--pad")) << mt.err;
    EXPECT_FALSE(fs::exists(tmp("x.vtu")));
}

// The following need the HT model.

TEST(Cli, ExtractUniformFullAndRegion) {
    const std::string in = tmp("ml_17x17x17_uint8.raw");
    ASSERT_EQ(run("-q sample marschner-lobb '" + in + "' --size 17").code, 0);

    const CliRun full = run("extract '" + in + "' '" + tmp("full.vtu") + "' --full");
    ASSERT_EQ(full.code, 0) << full.err;
    EXPECT_TRUE(contains(full.out, "24576 tets")) << full.out;  // 6 * 16^3
    EXPECT_TRUE(fs::exists(tmp("full.vtu")));

    const CliRun coarse = run("extract '" + in + "' '" + tmp("coarse.vtk") + "' --error 10%");
    ASSERT_EQ(coarse.code, 0) << coarse.err;
    EXPECT_TRUE(contains(coarse.out, "25.5 (10% of range)")) << coarse.out;
    EXPECT_EQ(slurp(tmp("coarse.vtk")).rfind("# vtk DataFile", 0), 0u);
    EXPECT_LT(fs::file_size(tmp("coarse.vtk")), fs::file_size(tmp("full.vtu")) * 4);

    const CliRun region =
        run("extract '" + in + "' '" + tmp("region.vtu") +
            "' --error 0 --box 4,4,4,12,12,12 --isovalue 128 --error-out inf --no-compress");
    ASSERT_EQ(region.code, 0) << region.err;
    EXPECT_FALSE(contains(slurp(tmp("region.vtu")), "vtkZLibDataCompressor"));
}

TEST(Cli, Demo) {
    const std::string dir = tmp("demo");
    const CliRun r = run("demo --out '" + dir + "' --size 9");
    ASSERT_EQ(r.code, 0) << r.err;
    for (const char* f :
         {"marschner-lobb_9x9x9_uint8.raw", "multiscale_9x9x9_uint8.raw", "marschner-lobb_full.vtu",
          "multiscale_error5pct.vtu", "multiscale_iso.vtu", "marschner-lobb_box.vtu"})
        EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;
    EXPECT_TRUE(contains(r.out, "paraview")) << r.out;
}

// verify --deep on both models: the MT's line says how many tet bounds it checked
// against exact errors (issue 13), in the HT's deep line's style; plain verify
// keeps its text.
TEST(Cli, VerifyDeepChecksTheMtBounds) {
    const std::string raw = tmp("verify_ml.raw"), path = tmp("verify_both.tlod");
    ASSERT_EQ(run("sample marschner-lobb '" + raw + "' --size 13").code, 0);
    const CliRun c = run("convert '" + raw + "' '" + path + "' --dims 13,13,13 --dtype u8 --model ht,mt");
    ASSERT_EQ(c.code, 0) << c.err;
    const CliRun d = run("verify '" + path + "' --deep");
    ASSERT_EQ(d.code, 0) << d.err;
    EXPECT_TRUE(contains(d.out, "; deep: MT full mesh = reference mesh (8640 tets); all ")) << d.out;
    EXPECT_TRUE(contains(d.out, " MT tet bounds >= exact errors (at most ")) << d.out;
    EXPECT_TRUE(contains(d.out, "; deep: all ")) << d.out;  // the HT's, as before
    const CliRun p = run("verify '" + path + "'");
    ASSERT_EQ(p.code, 0) << p.err;
    EXPECT_FALSE(contains(p.out, "deep")) << p.out;
    EXPECT_TRUE(contains(p.out, "; MT structure (")) << p.out;
}
