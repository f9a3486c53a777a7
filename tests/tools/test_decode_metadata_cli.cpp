// Metadata a target format cannot hold is left out and reported, never a
// refusal: a NRRD with `space units` (kept as the metadata key "nrrd:space
// units", which has a space MetaImage keys cannot hold) converts to a
// container that decodes to every volume format; each output reads back with
// the same samples, keeps every key its format can hold, and the command names
// the keys it left out on stderr.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "tetlod/converters/features.hpp"
#include "tetlod/converters/volume_formats.hpp"

namespace fs = std::filesystem;

namespace tetlod {
namespace {

using namespace tetlod_cli_test;

std::string q(const std::string& s) { return "'" + s + "'"; }
bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A 4x5x6 u8 NRRD with space, space units and a key/value pair; its samples.
std::vector<uint8_t> write_nrrd_with_units(const std::string& path) {
    std::vector<uint8_t> samples(4 * 5 * 6);
    for (std::size_t i = 0; i < samples.size(); ++i) samples[i] = uint8_t(i * 7 % 251);
    std::ofstream f(path, std::ios::binary);
    f << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 5 6\nspace: right-anterior-superior\n"
         "space directions: (0.5,0,0) (0,0.5,0) (0,0,2)\nspace units: \"mm\" \"mm\" \"mm\"\n"
         "encoding: raw\nscanner:=XR-7\n\n";
    f.write(reinterpret_cast<const char*>(samples.data()), std::streamsize(samples.size()));
    return samples;
}

TEST(DecodeMetadata, SpaceUnitsNeverStopAnOutputAndWhatIsLeftOutIsReported) {
    const std::string dir = tmp("meta_units");
    fs::remove_all(dir);
    fs::create_directories(dir);
    const auto samples = write_nrrd_with_units(dir + "/in.nrrd");
    const CliRun c = run("convert " + q(dir + "/in.nrrd") + " " + q(dir + "/in.tlod"));
    ASSERT_EQ(c.code, 0) << c.err;

    struct Out {
        std::string name;
        bool units_kept;   // can the format hold the key "nrrd:space units"?
        bool any_kept;     // can it hold metadata at all?
    };
    std::vector<Out> outs = {{"o.mhd", false, true}, {"o.mha", false, true}, {"o.nrrd", true, true},
                             {"o.nhdr", true, true}, {"o_4x5x6_uint8.raw", false, false}};
    if (volume_format_built("vdb")) outs.push_back({"o.vdb", true, true});
    if (volume_format_built("h5")) outs.push_back({"o.h5", true, true});
    for (const auto& o : outs) {
        SCOPED_TRACE(o.name);
        const std::string path = dir + "/" + o.name;
        const CliRun d = run("decode " + q(dir + "/in.tlod") + " " + q(path));
        ASSERT_EQ(d.code, 0) << d.err;
        EXPECT_TRUE(contains(d.out, "wrote")) << d.out;
        const bool warned = contains(d.err, "warning") && contains(d.err, "'nrrd:space units'");
        EXPECT_EQ(warned, !o.units_kept) << d.err;
        if (o.any_kept) {
            EXPECT_FALSE(contains(d.err, "'scanner'")) << d.err;
        }
        // -q is errors only (zstd's convention): the same decode, no warning.
        const CliRun dq = run("-q decode -f " + q(dir + "/in.tlod") + " " + q(path));
        ASSERT_EQ(dq.code, 0) << dq.err;
        EXPECT_EQ(dq.err, "");
        const Volume v = read_volume(path);
        ASSERT_EQ(v.data.size(), samples.size());
        EXPECT_TRUE(std::equal(samples.begin(), samples.end(), reinterpret_cast<const uint8_t*>(v.data.data())));
        if (!o.any_kept) continue;
        EXPECT_EQ(v.spacing, (Vec3{0.5, 0.5, 2}));
        EXPECT_EQ(v.metadata.count("scanner"), 1u);
        if (o.units_kept) {
            // NRRD writes it back as the `space units` field; the others as a key.
            ASSERT_EQ(v.metadata.count("nrrd:space units"), 1u);
            EXPECT_TRUE(contains(v.metadata.at("nrrd:space units"), "mm"));
        } else {
            EXPECT_EQ(v.metadata.count("nrrd:space units"), 0u);
        }
    }
}

}  // namespace
}  // namespace tetlod
