// The format dispatcher: every value type through every format and back to
// raw, bit-exact with metadata; name parsing; errors.
#include <gtest/gtest.h>

#include "format_test_util.hpp"
#include "tetlod/converters/features.hpp"
#include "tetlod/converters/volume_formats.hpp"

using namespace tetlod;
using namespace tetlod::test;

namespace {
std::vector<std::string> outputs(const std::string& dir, const std::string& stem) {
    std::vector<std::string> v = {dir + "/" + stem + ".nrrd", dir + "/" + stem + ".nhdr", dir + "/" + stem + ".mha",
                                  dir + "/" + stem + ".mhd"};
    if (TETLOD_HAVE_HDF5) v.push_back(dir + "/" + stem + ".h5:/data/volume");
    if (TETLOD_HAVE_OPENVDB) v.push_back(dir + "/" + stem + ".vdb");
    return v;
}
}  // namespace

TEST(VolumeFormats, EveryTypeThroughEveryFormatAndBackToRawIsBitExact) {
    const std::string dir = tmp_dir("vf_rt");
    for (ValueType t : kAllTypes) {
        Volume v = make_volume(t, {6, 5, 4});
        const std::string raw = dir + "/in_6x5x4_" + value_type_name(t) + ".raw";
        write_volume(v, raw);
        Volume from_raw = read_volume(raw);
        expect_same_samples(v, from_raw);
        for (const auto& out : outputs(dir, std::string("v_") + value_type_name(t))) {
            SCOPED_TRACE(out);
            write_volume(v, out);
            Volume r = read_volume(out);
            expect_same_samples(v, r);
            expect_same_geometry(v, r);
            EXPECT_EQ(r.field_name, v.field_name);
            EXPECT_EQ(r.units, v.units);
            for (const auto& [k, val] : v.metadata) EXPECT_EQ(r.metadata[k], val) << k;
            // ... and back to raw.
            const std::string back = dir + "/back_6x5x4_" + value_type_name(t) + ".raw";
            write_volume(r, back);
            EXPECT_EQ(read_file_bytes(back), read_file_bytes(raw));
        }
    }
}

TEST(VolumeFormats, MetadataSurvivesAChainOfFormats) {
    const std::string dir = tmp_dir("vf_chain");
    Volume v = make_volume(ValueType::I16);
    Volume cur = v;
    for (const auto& out : outputs(dir, "chain")) {
        SCOPED_TRACE(out);
        write_volume(cur, out);
        cur = read_volume(out);
        expect_same_samples(v, cur);
        expect_same_geometry(v, cur);
        for (const auto& [k, val] : v.metadata) EXPECT_EQ(cur.metadata[k], val) << k;
    }
}

TEST(VolumeFormats, LocateVolume) {
    auto l = locate_volume("a/b.H5:/x/y");
    EXPECT_EQ(l.format->name, "h5");
    EXPECT_EQ(l.file, "a/b.H5");
    EXPECT_EQ(l.dataset, "/x/y");
    l = locate_volume("c.hdf5:volume");
    EXPECT_EQ(l.file, "c.hdf5");
    EXPECT_EQ(l.dataset, "volume");
    EXPECT_EQ(locate_volume("x.nhdr").format->name, "nrrd");
    EXPECT_EQ(locate_volume("x.MHA").format->name, "metaimage");
    EXPECT_EQ(locate_volume("x.vdb").format->name, "vdb");
    EXPECT_EQ(locate_volume("x.raw").format->name, "raw");
    EXPECT_EQ(locate_volume("x.bin", "nrrd").format->name, "nrrd");
    expect_error([] { locate_volume("x.xyz"); }, ErrorCode::InvalidArgument, {"x.xyz"});
    expect_error([] { locate_volume("x.nrrd", "tiff"); }, ErrorCode::InvalidArgument, {"tiff"});
    EXPECT_EQ(volume_format_built("vdb"), TETLOD_HAVE_OPENVDB != 0);
    EXPECT_EQ(volume_format_built("h5"), TETLOD_HAVE_HDF5 != 0);
}

TEST(VolumeFormats, UnknownExtensionReadsAsRawOnlyWithDimsAndType) {
    const std::string dir = tmp_dir("vf_bin");
    std::vector<uint8_t> b(24);
    for (int i = 0; i < 24; ++i) b[i] = static_cast<uint8_t>(i);
    write_bytes(dir + "/x.bin", b.data(), b.size());
    expect_error([&] { read_volume(dir + "/x.bin"); }, ErrorCode::InvalidArgument, {"x.bin"});
    VolumeReadOptions o;
    o.dims = Dims{4, 3, 2};
    o.type = ValueType::U8;
    Volume v = read_volume(dir + "/x.bin", o);
    EXPECT_EQ(v.value(23), 23);
}

TEST(VolumeFormats, RealFilesGiveTheSameVolumeAsTheirRawOriginals) {
    struct Case {
        std::string file, raw;
    };
    std::vector<Case> cases = {{"original/headsq/quarter.nhdr", "headsq_64x64x93_int16.raw"},
                               {"original/HeadMRVolume.mhd", "head_mr_48x62x42_uint8.raw"}};
    if (TETLOD_HAVE_HDF5) cases.push_back({"headsq_64x64x93_int16.h5:/volume", "headsq_64x64x93_int16.raw"});
    if (TETLOD_HAVE_OPENVDB) cases.push_back({"headsq_64x64x93_int16.vdb", "headsq_64x64x93_int16.raw"});
    int checked = 0;
    for (const auto& c : cases) {
        const std::string raw = data_path(c.raw);
        const std::string file = data_path(c.file);
        if (!std::filesystem::exists(raw) || !std::filesystem::exists(locate_volume(file).file)) continue;
        SCOPED_TRACE(c.file);
        Volume a = read_volume(file);
        Volume b = read_volume(raw);
        expect_same_samples(a, b);
        ++checked;
    }
    if (checked == 0) GTEST_SKIP() << "shared data absent";
}
