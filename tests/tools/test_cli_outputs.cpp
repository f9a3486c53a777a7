// Issue 9, Must 1 and 5: no data destroyed by an output, and the documented exit
// codes (2 usage, 3 missing file, 4 bad data) for the reproducers of the issue.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"

namespace {

using namespace tetlod_cli_test;
namespace fs = std::filesystem;

// A fresh directory per test, holding a 9^3 u8 volume v_9x9x9_uint8.raw and its container.
std::string fresh_dir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::string d = tmp(std::string("out_") + info->name());
    fs::remove_all(d);
    fs::create_directories(d);
    EXPECT_EQ(run_no_force("-q sample sphere '" + d + "/v_9x9x9_uint8.raw' --size 9").code, 0);
    EXPECT_EQ(run_no_force("-q convert '" + d + "/v_9x9x9_uint8.raw' '" + d + "/v.tlod'").code, 0);
    return d;
}

void write_text(const std::string& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary);
    f << text;
}

TEST(CliOutputs, OutputThatIsTheInputIsRefusedEvenWithForce) {
    const std::string d = fresh_dir();
    const std::string raw = d + "/v_9x9x9_uint8.raw";
    const std::string before = slurp(raw);
    auto r = run("convert '" + raw + "' '" + raw + "'");  // run() passes -f
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("is an input"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(raw), before);
    // decode x.nrrd x.nrrd --error 10%
    ASSERT_EQ(run_no_force("-q decode '" + d + "/v.tlod' '" + d + "/x.nrrd'").code, 0);
    const std::string nrrd = slurp(d + "/x.nrrd");
    r = run("decode '" + d + "/x.nrrd' '" + d + "/x.nrrd' --error 10%");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(slurp(d + "/x.nrrd"), nrrd);
    // The data file a detached header names is an input too.
    ASSERT_EQ(run_no_force("-q decode '" + d + "/v.tlod' '" + d + "/h.nhdr'").code, 0);
    const std::string data = slurp(d + "/h.raw");
    r = run("convert '" + d + "/h.nhdr' '" + d + "/h.raw'");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("h.raw' is an input"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(d + "/h.raw"), data);
    // Through a symlink: the same file.
    fs::create_symlink(raw, d + "/alias.raw");
    r = run("decode '" + raw + "' '" + d + "/alias.raw' --dims 9,9,9 --dtype u8 --error 1");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(slurp(raw), before);
}

TEST(CliOutputs, ExistingOutputsAndSidecarsNeedForceAndAreAllReported) {
    const std::string d = fresh_dir();
    // decode x.tlod scan.nhdr must not silently replace an existing scan.raw.
    write_text(d + "/scan.raw", "precious");
    auto r = run_no_force("decode '" + d + "/v.tlod' '" + d + "/scan.nhdr'");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("scan.raw' already exists"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("-f"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(d + "/scan.raw"), "precious");
    EXPECT_FALSE(fs::exists(d + "/scan.nhdr"));  // nothing written at all
    r = run_no_force("-f decode '" + d + "/v.tlod' '" + d + "/scan.nhdr'");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(slurp(d + "/scan.raw").size(), 729u);
    EXPECT_NE(r.out.find("scan.nhdr"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("wrote    " + d + "/scan.raw"), std::string::npos) << r.out;
    // An existing plain output.
    r = run_no_force("convert '" + d + "/v_9x9x9_uint8.raw' '" + d + "/v.tlod'");
    EXPECT_EQ(r.code, 2) << r.err;
    // Medit: the .sol sidecar is checked before the .mesh is written.
    write_text(d + "/m.sol", "keep");
    r = run_no_force("extract '" + d + "/v.tlod' '" + d + "/m.mesh' --error 1");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(slurp(d + "/m.sol"), "keep");
    EXPECT_FALSE(fs::exists(d + "/m.mesh"));
    r = run_no_force("-f extract '" + d + "/v.tlod' '" + d + "/m.mesh' --error 1");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("wrote    " + d + "/m.sol"), std::string::npos) << r.out;
}

TEST(CliOutputs, SymlinkKeepsItsLinkAndFifoIsWrittenInPlace) {
    const std::string d = fresh_dir();
    write_text(d + "/target.raw", "old");
    fs::create_symlink("target.raw", d + "/link.raw");
    auto r = run_no_force("decode '" + d + "/v.tlod' '" + d + "/link.raw'");
    EXPECT_EQ(r.code, 2) << r.err;  // the target exists
    r = run_no_force("-f decode '" + d + "/v.tlod' '" + d + "/link.raw'");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::is_symlink(d + "/link.raw"));
    EXPECT_EQ(slurp(d + "/target.raw").size(), 729u);
    // A FIFO stays a FIFO (no -f needed: nothing is destroyed).
    ASSERT_EQ(::mkfifo((d + "/fifo").c_str(), 0600), 0);
    r = sh("cat '" + d + "/fifo' > '" + d + "/from_fifo' & '" + TETLOD_CLI_PATH + "' decode '" + d +
           "/v.tlod' '" + d + "/fifo' --format raw; wait");
    EXPECT_EQ(r.code, 0) << r.err;
    struct stat st {};
    ASSERT_EQ(::lstat((d + "/fifo").c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode));
    EXPECT_EQ(slurp(d + "/from_fifo").size(), 729u);
}

TEST(CliOutputs, DashIsStdoutAndStdinWhereTheFormatStreams) {
    const std::string d = fresh_dir();
    const std::string raw = slurp(d + "/v_9x9x9_uint8.raw");
    auto r = run_no_force("decode '" + d + "/v.tlod' - --format raw");  // sh() captures stdout
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out, raw);  // results went to stderr, not into the data
    EXPECT_NE(r.err.find("wrote"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists("-"));
    // Without --format, '-' carries raw samples (as zstd -d writes its content).
    r = run_no_force("decode '" + d + "/v.tlod' -");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out, raw);
    EXPECT_NE(r.err.find("--dims 9,9,9 --dtype u8"), std::string::npos) << r.err;
    r = sh("'" + std::string(TETLOD_CLI_PATH) + "' decode - '" + d + "/in.raw' < '" + d + "/v.tlod'");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(slurp(d + "/in.raw"), raw);
    r = sh("'" + std::string(TETLOD_CLI_PATH) + "' convert - '" + d +
           "/s.tlod' --dims 9,9,9 --dtype u8 < '" + d + "/v_9x9x9_uint8.raw'");
    EXPECT_EQ(r.code, 0) << r.err;
    // A .tlod through a pipe: convert to stdout, decode from stdin.
    const std::string cli = std::string("'") + TETLOD_CLI_PATH + "'";
    r = sh(cli + " convert '" + d + "/v_9x9x9_uint8.raw' - | " + cli + " decode - '" + d + "/piped.raw'");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(slurp(d + "/piped.raw"), raw);
    r = run_no_force("extract '" + d + "/v.tlod' - --format vtk --error 1");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out.rfind("# vtk DataFile", 0), 0u);
    // Formats that cannot stream refuse '-' as a usage error.
    for (const char* f : {"nhdr", "h5"}) {
        r = run_no_force(std::string("decode '") + d + "/v.tlod' - --format " + f);
        EXPECT_EQ(r.code, 2) << f << ": " << r.err;
        EXPECT_NE(r.err.find("standard output"), std::string::npos) << r.err;
    }
    r = run_no_force("extract '" + d + "/v.tlod' - --format mesh --error 1");
    EXPECT_EQ(r.code, 2) << r.err;
    // Read from stdin, the reports name it "<stdin>", not the spool file.
    r = sh(cli + " extract - '" + d + "/from_stdin.vtk' --error 1 < '" + d + "/v.tlod'");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("input    <stdin>:"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("tetlod-stdin"), std::string::npos) << r.out;
    r = sh(cli + " info - < '" + d + "/v.tlod'");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.out.rfind("<stdin>: tlod ", 0), 0u) << r.out;
    // '-' without --format: a usage error that says how to name the format.
    r = run_no_force("extract '" + d + "/v.tlod' - --error 1");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("--format"), std::string::npos) << r.err;
    // A broken container on stdin: the error speaks of <stdin>, not of the spool file.
    r = sh("head -c 300 '" + d + "/v.tlod' | " + cli + " decode - '" + d + "/broken.raw'");
    EXPECT_EQ(r.code, 4) << r.err;
    EXPECT_NE(r.err.find("<stdin>"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("tetlod-stdin"), std::string::npos) << r.err;
}

TEST(CliOutputs, Hdf5OutputAddsOrReplacesOneDatasetOnly) {
    if (std::system("/usr/bin/python3 -c 'import h5py' 2>/dev/null") != 0) GTEST_SKIP() << "python3-h5py not installed";
    const std::string d = fresh_dir();
    const std::string h5 = d + "/a.h5";
    ASSERT_EQ(sh("/usr/bin/python3 -c \"import h5py, numpy; f = h5py.File('" + h5 +
                 "', 'w'); f['keep/me'] = numpy.arange(5); f.attrs['note'] = 'file attr'; f['x'] = [1]\"")
                  .code,
              0);
    auto r = run_no_force("decode '" + d + "/v.tlod' '" + h5 + ":/lod/v'");
    EXPECT_EQ(r.code, 0) << r.err;
    r = run_no_force("decode '" + d + "/v.tlod' '" + h5 + ":/x'");  // exists: needs -f
    EXPECT_EQ(r.code, 2) << r.err;
    r = run_no_force("-f decode '" + d + "/v.tlod' '" + h5 + ":/x'");
    EXPECT_EQ(r.code, 0) << r.err;
    // Reading a.h5:/x and writing a.h5:/x is refused; another dataset is fine.
    r = run("decode '" + h5 + ":/x' '" + h5 + ":/x' --error 1");
    EXPECT_EQ(r.code, 2) << r.err;
    r = run_no_force("decode '" + h5 + ":/x' '" + h5 + ":/y' --error 1");
    EXPECT_EQ(r.code, 0) << r.err;
    r = sh("/usr/bin/python3 -c \"import h5py; f = h5py.File('" + h5 +
           "', 'r'); print(list(f['keep/me'][:]), f.attrs['note'], f['lod/v'].shape, f['x'].shape, "
           "f['y'].shape)\"");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("[0, 1, 2, 3, 4] file attr (9, 9, 9) (9, 9, 9) (9, 9, 9)"), std::string::npos) << r.out;
    // Refused before any work: an existing dataset without -f is reported even
    // when the input does not exist (the input would fail later, exit 3), and a
    // group at the path is never replaced, even with -f.
    r = run_no_force("decode '" + d + "/missing.tlod' '" + h5 + ":/x'");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("-f"), std::string::npos) << r.err;
    r = run("decode '" + d + "/missing.tlod' '" + h5 + ":/keep'");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("not a dataset"), std::string::npos) << r.err;
    r = run("decode '" + d + "/missing.tlod' '" + h5 + ":/new'");
    EXPECT_EQ(r.code, 3) << r.err;  // a new dataset: the missing input is the problem
}

TEST(CliOutputs, ExitCodesOfTheIssue) {
    const std::string d = fresh_dir();
    // Non-UTF-8 --meta: usage (2), not an internal error.
    auto r = run_no_force("convert '" + d + "/v_9x9x9_uint8.raw' '" + d + "/m.tlod' --meta \"k=$(printf '\\377')\"");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("UTF-8"), std::string::npos) << r.err;
    // Zero-sized NRRD: bad data (4).
    write_text(d + "/z.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 0 4 4\nencoding: raw\n\n");
    r = run_no_force("convert '" + d + "/z.nrrd' '" + d + "/z.tlod'");
    EXPECT_EQ(r.code, 4) << r.err;
    // Bad-magic .tlod: 4; missing .tlod: 3 naming the file.
    write_text(d + "/bad.tlod", "this is not a container at all");
    for (const std::string& cmd : {"extract '" + d + "/bad.tlod' '" + d + "/o.vtu' --error 1",
                                  "decode '" + d + "/bad.tlod' '" + d + "/o.raw'", "stats '" + d + "/bad.tlod'",
                                  "info '" + d + "/bad.tlod'"}) {
        r = run_no_force(cmd);
        EXPECT_EQ(r.code, 4) << cmd << ": " << r.err;
    }
    for (const std::string& cmd : {"extract '" + d + "/missing.tlod' '" + d + "/o.vtu' --error 1",
                                  "decode '" + d + "/missing.tlod' '" + d + "/o.raw'",
                                  "stats '" + d + "/missing.tlod'"}) {
        r = run_no_force(cmd);
        EXPECT_EQ(r.code, 3) << cmd << ": " << r.err;
        EXPECT_NE(r.err.find("missing.tlod"), std::string::npos) << r.err;
    }
    // An MT-only container is used without --model mt; --model ht names the flag.
    ASSERT_EQ(run_no_force("-q convert '" + d + "/v_9x9x9_uint8.raw' '" + d + "/mt.tlod' --model mt").code, 0);
    for (const std::string& cmd : {"extract '" + d + "/mt.tlod' '" + d + "/e.vtu' --error 1",
                                  "decode '" + d + "/mt.tlod' '" + d + "/d.raw'",
                                  "decode '" + d + "/mt.tlod' '" + d + "/dl.raw' --error 1",
                                  "stats '" + d + "/mt.tlod'"}) {
        r = run_no_force(cmd);
        EXPECT_EQ(r.code, 0) << cmd << ": " << r.err;
    }
    EXPECT_EQ(slurp(d + "/d.raw"), slurp(d + "/v_9x9x9_uint8.raw"));
    r = run_no_force("extract '" + d + "/mt.tlod' '" + d + "/e2.vtu' --error 1 --model ht");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("--model"), std::string::npos) << r.err;
    // The exit codes are documented in --help.
    r = run_no_force("--help");
    EXPECT_NE(r.out.find("Exit codes"), std::string::npos);
    EXPECT_NE(r.out.find("-f,--force"), std::string::npos);
}

}  // namespace
