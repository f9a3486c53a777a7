// Same input, same options -> same bytes: for any -T thread count, and across
// runs with SOURCE_DATE_EPOCH fixing the creation time (the reproducible-builds
// convention); a malformed SOURCE_DATE_EPOCH is a usage error.
#include <filesystem>

#include "cli_runner.hpp"

namespace {

using namespace tetlod_cli_test;
namespace fs = std::filesystem;

std::string dir() {
    const std::string d = tmp("reproducible");
    fs::create_directories(d);
    return d;
}

TEST(CliReproducible, ContainersAndMeshesAreIdenticalForAnyThreadCount) {
    const std::string d = dir();
    ASSERT_EQ(run("-q sample multiscale '" + d + "/m_37x37x37_uint8.raw' --size 37").code, 0);
    std::string first_tlod, first_vtu, first_raw;
    for (const char* threads : {"1", "2", "3"}) {
        SCOPED_TRACE(std::string("-T ") + threads);
        const std::string t = d + "/t" + threads;
        auto r = sh("SOURCE_DATE_EPOCH=1700000000 '" + std::string(TETLOD_CLI_PATH) + "' -f -T " + threads +
                    " convert '" + d + "/m_37x37x37_uint8.raw' '" + t + ".tlod' --model ht,mt");
        ASSERT_EQ(r.code, 0) << r.err;
        r = run("--threads " + std::string(threads) + " extract '" + t + ".tlod' '" + t + ".vtu' --error 2%");
        ASSERT_EQ(r.code, 0) << r.err;
        r = run("decode -T " + std::string(threads) + " '" + t + ".tlod' '" + t + ".raw'");
        ASSERT_EQ(r.code, 0) << r.err;
        if (first_tlod.empty()) {
            first_tlod = slurp(t + ".tlod"), first_vtu = slurp(t + ".vtu"), first_raw = slurp(t + ".raw");
            ASSERT_FALSE(first_tlod.empty());
            continue;
        }
        EXPECT_TRUE(slurp(t + ".tlod") == first_tlod) << "container differs";
        EXPECT_TRUE(slurp(t + ".vtu") == first_vtu) << "mesh differs";
        EXPECT_TRUE(slurp(t + ".raw") == first_raw) << "decoded volume differs";
    }
    auto r = run("info '" + d + "/t1.tlod'");
    EXPECT_NE(r.out.find("2023-11-14T22:13:20Z"), std::string::npos) << r.out;
}

// Out-of-core conversion: raw input read plane by plane under --memory gives
// the bytes of the in-memory path (--in-memory) and of a format read whole
// (NRRD); a budget below what the plan needs is refused with the figure.
TEST(CliReproducible, PlaneByPlaneConversionGivesTheInMemoryBytes) {
    const std::string d = dir();
    ASSERT_EQ(run("-q sample multiscale '" + d + "/o_70x70x70_uint8.raw' --size 70").code, 0);
    const std::string cli = "SOURCE_DATE_EPOCH=1700000000 '" + std::string(TETLOD_CLI_PATH) + "' -f -q ";
    const std::string raw = d + "/o_70x70x70_uint8.raw";
    auto r = sh(cli + "convert '" + raw + "' '" + d + "/mem.tlod' --in-memory --pad");
    ASSERT_EQ(r.code, 0) << r.err;
    for (const char* memory : {"", "--memory 64M", "--memory 0.1G"}) {
        SCOPED_TRACE(memory);
        r = sh(cli + "convert '" + raw + "' '" + d + "/planes.tlod' --pad " + memory);
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_TRUE(slurp(d + "/planes.tlod") == slurp(d + "/mem.tlod"));
    }
    r = sh(cli + "convert '" + raw + "' '" + d + "/small.tlod' --memory 1M");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("--memory"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(d + "/small.tlod"));
    for (const char* bad : {"lots", "12X", "-5M", "0"}) {
        r = sh(cli + "convert '" + raw + "' '" + d + "/bad.tlod' --memory " + bad);
        EXPECT_EQ(r.code, 2) << bad << ": " << r.err;
        EXPECT_NE(r.err.find("--memory"), std::string::npos) << r.err;
    }
}

TEST(CliReproducible, MalformedSourceDateEpochIsAUsageError) {
    const std::string d = dir();
    ASSERT_EQ(run("-q sample sphere '" + d + "/s_9x9x9_uint8.raw' --size 9").code, 0);
    for (const char* bad : {"abc", "-5", "12x", "", "99999999999999999999"}) {
        auto r = sh("SOURCE_DATE_EPOCH='" + std::string(bad) + "' '" + std::string(TETLOD_CLI_PATH) +
                    "' -f convert '" + d + "/s_9x9x9_uint8.raw' '" + d + "/bad.tlod'");
        EXPECT_EQ(r.code, 2) << bad << ": " << r.err;
        EXPECT_NE(r.err.find("SOURCE_DATE_EPOCH"), std::string::npos) << r.err;
    }
    EXPECT_EQ(run("-T -1 info '" + d + "/s_9x9x9_uint8.raw'").code, 2);
}

}  // namespace

namespace {

// Progress bars: forced on with --progress (even when stderr is not a terminal,
// as here), never with --no-progress or -q, and not by default off a terminal.
TEST(CliProgress, FlagsDecideWhetherBarsAreDrawn) {
    const std::string d = dir();
    ASSERT_EQ(run("-q sample multiscale '" + d + "/p_33x33x33_uint8.raw' --size 33").code, 0);
    ASSERT_EQ(run("-q convert '" + d + "/p_33x33x33_uint8.raw' '" + d + "/p.tlod'").code, 0);
    auto r = run("--progress decode '" + d + "/p.tlod' '" + d + "/p.raw'");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("decoding ["), std::string::npos) << r.err;
    r = run("--progress convert '" + d + "/p_33x33x33_uint8.raw' '" + d + "/p2.tlod'");
    EXPECT_NE(r.err.find("encoding ["), std::string::npos) << r.err;
    // The MT: its build as a percentage, then its encoding (no count).
    r = run("--progress convert '" + d + "/p_33x33x33_uint8.raw' '" + d + "/p3.tlod' --model ht,mt");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("building the MT ["), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("encoding the MT"), std::string::npos) << r.err;
    r = run("--no-progress convert '" + d + "/p_33x33x33_uint8.raw' '" + d + "/p3.tlod' --model ht,mt -f");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.err.find("encoding the MT"), std::string::npos) << r.err;
    for (const char* off : {"--no-progress", "-q", ""}) {
        r = run(std::string(off) + " decode '" + d + "/p.tlod' '" + d + "/p.raw'");
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_EQ(r.err.find("decoding ["), std::string::npos) << off << ": " << r.err;
    }
}

}  // namespace
