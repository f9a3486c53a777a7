// `tetlod decode` and `tetlod extract --model mt` as a user runs them: decoding a
// container to every volume format and reading it back (bit-exact values, type,
// spacing, origin, user metadata); level-of-detail decoding (--error) checked by
// recomputing the deviation here; the MT path of extract read back from a Medit
// file; bad inputs fail clearly and write nothing.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include "cli_runner.hpp"
#include "tetlod/converters/volume_formats.hpp"
#include "tetlod/core/volume.hpp"

namespace fs = std::filesystem;

namespace tetlod {
namespace {

using namespace tetlod_cli_test;


bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

std::string q(const std::string& s) { return "'" + s + "'"; }

// A smooth field with noise, in the type's own range.
Volume make_volume(Dims d, ValueType t, uint32_t seed) {
    Volume v = Volume::allocate(d, t);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> noise(-4, 4);
    for (int64_t z = 0; z < d.z; ++z)
        for (int64_t y = 0; y < d.y; ++y)
            for (int64_t x = 0; x < d.x; ++x) {
                double f = 120 + 90 * std::sin(0.45 * x + 0.2 * z) * std::cos(0.35 * y) + noise(rng);
                if (t == ValueType::I16) f = f * 40 - 3000;
                if (t == ValueType::F32) f = f * 0.0173 - 1.1;
                v.set_value(d.index(x, y, z), is_float(t) ? f : std::round(f));
            }
    return v;
}

// Writes a raw volume, converts it to .tlod with geometry and a user key; returns the .tlod path.
std::string make_container(const Volume& v, const std::string& stem) {
    const std::string raw = tmp(stem + "_" + std::to_string(v.dims.x) + "x" +
                                std::to_string(v.dims.y) + "x" + std::to_string(v.dims.z) + "_" +
                                value_type_name(v.type) + ".raw");
    {
        std::ofstream f(raw, std::ios::binary);
        f.write(reinterpret_cast<const char*>(v.data.data()), std::streamsize(v.data.size()));
    }
    const std::string tlod = tmp(stem + ".tlod");
    const CliRun c = run("-q convert " + q(raw) + " " + q(tlod) +
                         " --spacing 0.5,1.25,2 --origin -3,4.5,10 --meta patient=anon");
    EXPECT_EQ(c.code, 0) << c.err;
    return tlod;
}

struct Deviation {
    double max = 0, sum = 0;
};
Deviation deviation(const Volume& a, const Volume& b) {
    Deviation d;
    for (int64_t i = 0; i < a.count(); ++i) {
        const double e = std::fabs(a.value(i) - b.value(i));
        d.max = std::max(d.max, e);
        d.sum += e;
    }
    return d;
}

std::vector<std::string> output_names() {
    std::vector<std::string> names = {"out.raw", "out.nrrd", "out.nhdr", "out.mhd", "out.mha"};
    if (volume_format_built("h5")) {
        names.push_back("out.h5:/data/volume");
        names.push_back("plain.h5");  // default dataset /volume
    }
    if (volume_format_built("vdb")) names.push_back("out.vdb");
    return names;
}

class DecodeFormats : public ::testing::TestWithParam<ValueType> {};

TEST_P(DecodeFormats, EveryFormatReadsBackBitExactWithMetadata) {
    const ValueType t = GetParam();
    const std::string tn = value_type_name(t);
    const Volume v = make_volume(Dims{13, 10, 7}, t, 11);
    const std::string tlod = make_container(v, "c_" + tn);
    for (const std::string& name : output_names()) {
        SCOPED_TRACE(name);
        const std::string path = tmp(tn + "_" + name);
        const CliRun r = run("decode " + q(tlod) + " " + q(path));
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_TRUE(contains(r.out, "wrote")) << r.out;
        VolumeReadOptions ro;
        if (name == "out.raw") {  // raw carries no header: the geometry as decode prints it
            EXPECT_TRUE(contains(r.out, "--dims 13,10,7 --dtype " + tn)) << r.out;
            ro.dims = Dims{13, 10, 7};
            ro.type = t;
        }
        const Volume back = read_volume(path, ro);
        EXPECT_EQ(back.dims, v.dims);
        ASSERT_EQ(back.type, t);
        EXPECT_EQ(back.data, v.data);
        if (name == "out.raw") continue;
        for (int a = 0; a < 3; ++a) {
            EXPECT_DOUBLE_EQ(back.spacing[a], (std::array<double, 3>{0.5, 1.25, 2})[a]);
            EXPECT_DOUBLE_EQ(back.origin[a], (std::array<double, 3>{-3, 4.5, 10})[a]);
        }
        ASSERT_TRUE(back.metadata.count("patient")) << "user key lost";
        EXPECT_EQ(back.metadata.at("patient"), "anon");
    }
}

TEST_P(DecodeFormats, ErrorZeroIsExactAndFivePercentIsBounded) {
    const ValueType t = GetParam();
    const std::string tn = value_type_name(t);
    const Volume v = make_volume(Dims{17, 12, 9}, t, 5);
    const std::string tlod = make_container(v, "e_" + tn);

    for (const std::string& input : {tlod, std::string()}) {  // container, then plain volume
        const std::string src = input.empty() ? tmp("e_" + tn + ".nrrd") : input;
        if (input.empty()) {
            ASSERT_EQ(run("-q decode " + q(tlod) + " " + q(src)).code, 0);
        }
        SCOPED_TRACE(src);
        const CliRun zero = run("decode " + q(src) + " " + q(tmp("zero_" + tn + ".nrrd")) + " --error 0");
        ASSERT_EQ(zero.code, 0) << zero.err;
        EXPECT_TRUE(contains(zero.out, "deviation max 0")) << zero.out;
        EXPECT_TRUE(contains(zero.out, "over 1836 grid points")) << zero.out;
        const Volume z = read_volume(tmp("zero_" + tn + ".nrrd"));
        EXPECT_EQ(z.type, t);
        EXPECT_EQ(z.data, v.data);
        EXPECT_EQ(z.metadata.count("patient"), 1u);

        const CliRun five = run("decode " + q(src) + " " + q(tmp("five_" + tn + ".mha")) + " --error 5%");
        ASSERT_EQ(five.code, 0) << five.err;
        const Volume f = read_volume(tmp("five_" + tn + ".mha"));
        ASSERT_EQ(f.type, t);
        ASSERT_EQ(f.dims, v.dims);
        const auto range = v.range();
        const double e = 0.05 * (range[1] - range[0]);
        const Deviation d = deviation(f, v);
        // Integer types round the interpolated value to nearest: within e rounded to nearest.
        const double bound = is_float(t) ? e * (1 + 1e-6) : std::floor(e + 0.5);
        EXPECT_LE(d.max, bound);
        EXPECT_GT(d.max, 0.0) << "5% should coarsen this field";
        EXPECT_NE(f.data, v.data);
        if (!is_float(t)) {  // the printed deviation is the one recomputed here
            EXPECT_TRUE(contains(five.out, "deviation max " + std::to_string(int64_t(d.max)) + " ("))
                << five.out;
        }
        EXPECT_TRUE(contains(five.out, "deviation max")) << five.out;
        EXPECT_TRUE(contains(five.out, "tets")) << five.out;
    }
}

INSTANTIATE_TEST_SUITE_P(Types, DecodeFormats,
                         ::testing::Values(ValueType::U8, ValueType::I16, ValueType::F32),
                         [](const auto& info) { return std::string(value_type_name(info.param)); });

TEST(DecodeLod, RegionsFullAndMt) {
    const Volume v = make_volume(Dims{17, 17, 17}, ValueType::U8, 9);
    const std::string tlod = make_container(v, "lod");
    // --full decodes the full-resolution mesh: the original.
    ASSERT_EQ(run("-q decode " + q(tlod) + " " + q(tmp("full.nrrd")) + " --full").code, 0);
    EXPECT_EQ(read_volume(tmp("full.nrrd")).data, v.data);
    // A box at error 0 inside, inf outside: exact inside the box.
    const CliRun box = run("decode " + q(tlod) + " " + q(tmp("box.nrrd")) +
                           " --error 0 --box 4,4,4,10,10,10 --error-out inf");
    ASSERT_EQ(box.code, 0) << box.err;
    const Volume b = read_volume(tmp("box.nrrd"));
    for (int64_t z = 4; z <= 10; ++z)
        for (int64_t y = 4; y <= 10; ++y)
            for (int64_t x = 4; x <= 10; ++x) ASSERT_EQ(b.value(x, y, z), v.value(x, y, z));
    EXPECT_NE(b.data, v.data);
    // The MT from the plain volume: exact at error 0, bounded at 5%.
    const std::string raw = tmp("lod_17x17x17_u8.raw");
    const CliRun mt0 = run("decode " + q(raw) + " " + q(tmp("mt0.mhd")) + " --error 0 --model mt");
    ASSERT_EQ(mt0.code, 0) << mt0.err;
    EXPECT_TRUE(contains(mt0.out, "MT")) << mt0.out;
    EXPECT_EQ(read_volume(tmp("mt0.mhd")).data, v.data);
    const CliRun mt5 = run("decode " + q(raw) + " " + q(tmp("mt5.mhd")) + " --error 5% --model mt");
    ASSERT_EQ(mt5.code, 0) << mt5.err;
    const auto range = v.range();
    EXPECT_LE(deviation(read_volume(tmp("mt5.mhd")), v).max,
              std::floor(0.05 * (range[1] - range[0]) + 0.5));
}

TEST(DecodeLod, PaddedContainer) {
    const Volume v = make_volume(Dims{21, 19, 13}, ValueType::U8, 6);
    const std::string raw = tmp("pad_21x19x13_u8.raw");
    {
        std::ofstream f(raw, std::ios::binary);
        f.write(reinterpret_cast<const char*>(v.data.data()), std::streamsize(v.data.size()));
    }
    ASSERT_EQ(run("-q convert " + q(raw) + " " + q(tmp("pad.tlod")) + " --pad").code, 0);
    const CliRun zero = run("decode " + q(tmp("pad.tlod")) + " " + q(tmp("pad0.nrrd")) + " --error 0");
    ASSERT_EQ(zero.code, 0) << zero.err;
    EXPECT_EQ(read_volume(tmp("pad0.nrrd")).data, v.data);
    ASSERT_EQ(run("-q decode " + q(tmp("pad.tlod")) + " " + q(tmp("pad10.nrrd")) + " --error 10").code, 0);
    const Volume ten = read_volume(tmp("pad10.nrrd"));
    EXPECT_EQ(ten.dims, v.dims);
    EXPECT_LE(deviation(ten, v).max, 10.0);  // an integer bound holds exactly after rounding
}

// libhdf5 stamps creation and modification times (in seconds) into the objects
// it creates unless told not to: two decodes a second apart into fresh files
// must still give the same bytes, for a dataset in the root group, one under
// new parent groups, and a second dataset added to that file.
TEST(DecodeHdf5, TwoDecodesToFreshFilesAreByteIdentical) {
    if (!volume_format_built("h5")) GTEST_SKIP() << "built without HDF5";
    const Volume v = make_volume(Dims{15, 11, 9}, ValueType::I16, 3);
    const std::string tlod = make_container(v, "h5repro");
    auto decode_all = [&](const std::string& stem) {
        for (const std::string& args : {" " + q(tmp(stem + "_root.h5") + ":/data"),
                                        " " + q(tmp(stem + "_nested.h5") + ":/a/b/volume"),
                                        " " + q(tmp(stem + "_nested.h5") + ":/a/c/lod") + " --error 5%"}) {
            const CliRun r = run("-q decode " + q(tlod) + args);
            ASSERT_EQ(r.code, 0) << args << ": " << r.err;
        }
    };
    for (const std::string stem : {"h5first", "h5second"}) {
        fs::remove(tmp(stem + "_root.h5"));
        fs::remove(tmp(stem + "_nested.h5"));
    }
    decode_all("h5first");
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // a different second
    decode_all("h5second");
    for (const char* which : {"_root.h5", "_nested.h5"}) {
        SCOPED_TRACE(which);
        const std::string first = slurp(tmp(std::string("h5first") + which));
        ASSERT_FALSE(first.empty());
        EXPECT_TRUE(first == slurp(tmp(std::string("h5second") + which))) << "the two decodes differ";
    }
    const Volume back = read_volume(tmp("h5second_nested.h5") + ":/a/b/volume");
    EXPECT_EQ(back.data, v.data);
}

TEST(DecodeLod, BadInputsFailClearlyAndWriteNothing) {
    const Volume v = make_volume(Dims{9, 9, 9}, ValueType::U8, 2);
    const std::string tlod = make_container(v, "bad");
    struct Case {
        std::string args, message;
        int code;
    };
    const std::string o = tmp("never.nrrd");
    const std::vector<Case> cases = {
        {"decode " + q(tmp("absent.tlod")) + " " + q(o), "absent.tlod", 3},
        {"decode " + q(tlod) + " " + q(tmp("never.xyz")), "never.xyz", 2},
        {"decode " + q(tlod) + " " + q(o) + " --error abc", "--error", 2},
        {"decode " + q(tlod) + " " + q(o) + " --box 1,1,1,2,2,2", "--error", 2},
        {"decode " + q(tlod) + " " + q(o) + " --error 1 --error-out 2", "--error-out", 2},
        {"decode " + q(tlod) + " " + q(o) + " --error 1 --box 20,20,20,30,30,30", "outside", 2},
        {"decode " + q(tlod) + " " + q(o) + " --error 1 --model mt", "--model mt", 2},  // the container holds no MT: names the flag
        {"decode " + q(tlod) + " " + q(o) + " --model mt", "--model", 2},
        {"decode " + q(tmp("bad_9x9x9_u8.raw")) + " " + q(o) + " --error 1 --model xx", "--model", 2},
    };
    {  // a truncated container
        const std::string bytes = slurp(tlod);
        std::ofstream f(tmp("trunc.tlod"), std::ios::binary);
        f << bytes.substr(0, bytes.size() / 2);
    }
    for (const Case& c : cases) {
        SCOPED_TRACE(c.args);
        const CliRun r = run(c.args);
        EXPECT_NE(r.code, 0);
        EXPECT_EQ(r.code, c.code) << r.err;
        EXPECT_TRUE(contains(r.err, "tetlod: error:")) << r.err;
        EXPECT_TRUE(contains(r.err, c.message)) << r.err;
        EXPECT_EQ(r.out, "");
    }
    const CliRun tr = run("decode " + q(tmp("trunc.tlod")) + " " + q(o));
    EXPECT_NE(tr.code, 0);
    EXPECT_TRUE(contains(tr.err, "trunc.tlod")) << tr.err;
    for (const auto& e : fs::directory_iterator(TETLOD_TEST_TMP))
        EXPECT_FALSE(contains(e.path().filename().string(), "never")) << e.path();
}

// Reads a Medit .mesh + .sol as the writer produces them.
struct Medit {
    std::vector<std::array<double, 3>> points;
    std::vector<std::array<int64_t, 4>> tets;
    std::vector<double> values;
};
Medit read_medit(const std::string& path) {
    Medit m;
    std::istringstream in(slurp(path));
    std::string word;
    while (in >> word) {
        if (word == "Vertices") {
            std::size_t n = 0;
            in >> n;
            m.points.resize(n);
            for (auto& p : m.points) {
                int ref;
                in >> p[0] >> p[1] >> p[2] >> ref;
            }
        } else if (word == "Tetrahedra") {
            std::size_t n = 0;
            in >> n;
            m.tets.resize(n);
            for (auto& t : m.tets) {
                int ref;
                in >> t[0] >> t[1] >> t[2] >> t[3] >> ref;
            }
        }
    }
    std::istringstream sol(slurp(fs::path(path).replace_extension(".sol").string()));
    while (sol >> word)
        if (word == "SolAtVertices") {
            std::size_t n = 0;
            int a, b;
            sol >> n >> a >> b;
            m.values.resize(n);
            for (double& x : m.values) sol >> x;
        }
    return m;
}

// Checks the mesh read back: indices valid, tets positively oriented, volumes summing to
// the data box, vertex values equal to the samples at their positions (spacing 1).
void check_mesh(const Medit& m, const Volume& v) {
    ASSERT_EQ(m.values.size(), m.points.size());
    double total = 0;
    for (const auto& t : m.tets) {
        std::array<std::array<double, 3>, 4> p;
        for (int i = 0; i < 4; ++i) {
            ASSERT_GE(t[i], 1);
            ASSERT_LE(t[i], int64_t(m.points.size()));
            p[i] = m.points[std::size_t(t[i] - 1)];
        }
        const double ax = p[1][0] - p[0][0], ay = p[1][1] - p[0][1], az = p[1][2] - p[0][2];
        const double bx = p[2][0] - p[0][0], by = p[2][1] - p[0][1], bz = p[2][2] - p[0][2];
        const double cx = p[3][0] - p[0][0], cy = p[3][1] - p[0][1], cz = p[3][2] - p[0][2];
        const double det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
        ASSERT_GT(det, 0);
        total += det / 6;
    }
    EXPECT_NEAR(total, double((v.dims.x - 1) * (v.dims.y - 1) * (v.dims.z - 1)), 1e-6);
    for (std::size_t i = 0; i < m.points.size(); ++i) {
        const auto& p = m.points[i];
        EXPECT_EQ(m.values[i], v.value(int64_t(p[0]), int64_t(p[1]), int64_t(p[2])));
    }
}

TEST(ExtractMt, FullAndLodFromAVolume) {
    const Dims d{9, 8, 7};
    const Volume v = make_volume(d, ValueType::U8, 4);
    const std::string raw = tmp("mt_9x8x7_u8.raw");
    {
        std::ofstream f(raw, std::ios::binary);
        f.write(reinterpret_cast<const char*>(v.data.data()), std::streamsize(v.data.size()));
    }
    const int64_t cells = 8 * 7 * 6;
    const CliRun full = run("extract " + q(raw) + " " + q(tmp("mt_full.mesh")) + " --model mt --full");
    ASSERT_EQ(full.code, 0) << full.err;
    EXPECT_TRUE(contains(full.out, std::to_string(5 * cells) + " tets")) << full.out;
    for (const char* part : {"largest error", "build", "extract", "wrote"})
        EXPECT_TRUE(contains(full.out, part)) << full.out;
    const Medit fm = read_medit(tmp("mt_full.mesh"));
    EXPECT_EQ(int64_t(fm.tets.size()), 5 * cells);
    EXPECT_EQ(int64_t(fm.points.size()), d.count());
    check_mesh(fm, v);

    const CliRun lod = run("extract " + q(raw) + " " + q(tmp("mt_lod.mesh")) + " --model mt --error 5%");
    ASSERT_EQ(lod.code, 0) << lod.err;
    const Medit lm = read_medit(tmp("mt_lod.mesh"));
    EXPECT_LT(lm.tets.size(), fm.tets.size());
    check_mesh(lm, v);

    const CliRun region = run("extract " + q(raw) + " " + q(tmp("mt_region.vtu")) +
                              " --model mt --error 0 --box 2,2,2,5,5,5 --isovalue 120");
    ASSERT_EQ(region.code, 0) << region.err;
    EXPECT_TRUE(contains(region.out, "in the region")) << region.out;
}

TEST(ExtractMt, PadAndContainerAreClearErrors) {
    const Volume v = make_volume(Dims{9, 9, 9}, ValueType::U8, 1);
    const std::string tlod = make_container(v, "mtc");
    const std::string raw = tmp("mtc_9x9x9_u8.raw");
    const CliRun pad = run("extract " + q(raw) + " " + q(tmp("never_pad.vtu")) + " --model mt --full --pad");
    EXPECT_EQ(pad.code, 2) << pad.err;
    EXPECT_TRUE(contains(pad.err, "--pad")) << pad.err;
    EXPECT_EQ(pad.out, "");
    EXPECT_FALSE(fs::exists(tmp("never_pad.vtu")));
    const CliRun c = run("extract " + q(tlod) + " " + q(tmp("never_c.vtu")) + " --model mt --error 1");
    EXPECT_NE(c.code, 0);
    EXPECT_TRUE(contains(c.err, "--model mt")) << c.err;
    EXPECT_FALSE(fs::exists(tmp("never_c.vtu")));
}

}  // namespace
}  // namespace tetlod
