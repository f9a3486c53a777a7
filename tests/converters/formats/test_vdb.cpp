// OpenVDB reader/writer: round trips for every type; the real pyopenvdb-written
// copies in the shared data against their raw originals; grid selection; bad
// inputs.
#include <gtest/gtest.h>

#include "format_test_util.hpp"
#include "tetlod/converters/vdb.hpp"

using namespace tetlod;
using namespace tetlod::test;

TEST(Vdb, RoundTripEveryType) {
    const std::string dir = tmp_dir("vdb_rt");
    for (ValueType t : kAllTypes) {
        SCOPED_TRACE(value_type_name(t));
        Volume v = make_volume(t, {9, 6, 4});
        write_vdb(v, dir + "/v.vdb");
        auto grids = list_vdb_grids(dir + "/v.vdb");
        ASSERT_EQ(grids.size(), 1u);
        EXPECT_EQ(grids[0].first, "density");
        Volume r = read_vdb(dir + "/v.vdb");
        expect_same_samples(v, r);
        expect_same_geometry(v, r);
        EXPECT_EQ(r.field_name, v.field_name);
        EXPECT_EQ(r.units, v.units);
        for (const auto& [k, val] : v.metadata) EXPECT_EQ(r.metadata[k], val) << k;
        VolumeReadOptions o;
        o.grid = "density";
        expect_same_samples(v, read_vdb(dir + "/v.vdb", o));
    }
}

TEST(Vdb, ZeroBordersKeepTheFullExtent) {
    const std::string dir = tmp_dir("vdb_zero");
    Volume v = Volume::allocate({6, 5, 4}, ValueType::F32);
    v.as<float>()[v.dims.index(2, 2, 2)] = 7.5f;
    write_vdb(v, dir + "/z.vdb");
    Volume r = read_vdb(dir + "/z.vdb");
    expect_same_samples(v, r);
    Volume empty = Volume::allocate({3, 3, 3}, ValueType::U16);
    write_vdb(empty, dir + "/e.vdb");
    expect_same_samples(empty, read_vdb(dir + "/e.vdb"));
}

TEST(Vdb, RealPyopenvdbFilesMatchTheirRawOriginals) {
    struct Case {
        const char* name;
        ValueType type;
        Dims dims;
    };
    const Case cases[] = {{"bucky_32x32x32_uint8", ValueType::U8, {32, 32, 32}},
                          {"bucky_128x128x128_uint8", ValueType::U8, {128, 128, 128}},
                          {"neghip_64x64x64_uint8", ValueType::U8, {64, 64, 64}},
                          {"headsq_64x64x93_int16", ValueType::I16, {64, 64, 93}},
                          {"m4_total_density_25x22x31_float32", ValueType::F32, {25, 22, 31}}};
    int checked = 0;
    for (const auto& c : cases) {
        const std::string vdb = data_path(std::string(c.name) + ".vdb"), raw = data_path(std::string(c.name) + ".raw");
        if (!std::filesystem::exists(vdb) || !std::filesystem::exists(raw)) continue;
        SCOPED_TRACE(c.name);
        Volume v = read_vdb(vdb);
        EXPECT_EQ(v.dims, c.dims);
        // original_dtype in the grid metadata restores the integer type (values exact).
        EXPECT_EQ(v.type, c.type);
        auto bytes = read_file_bytes(raw);
        ASSERT_EQ(bytes.size(), v.data.size());
        EXPECT_TRUE(std::memcmp(bytes.data(), v.data.data(), bytes.size()) == 0);
        EXPECT_EQ(v.field_name, "density");
        EXPECT_EQ(v.metadata.count("description"), 1u);
        ++checked;
    }
    if (checked == 0) GTEST_SKIP() << "shared .vdb data absent";
    const std::string hs = data_path("headsq_64x64x93_int16.vdb");
    if (std::filesystem::exists(hs)) {
        Volume v = read_vdb(hs);
        EXPECT_NEAR(v.spacing[0], 3.2, 1e-12);
        EXPECT_NEAR(v.spacing[1], 3.2, 1e-12);
        EXPECT_NEAR(v.spacing[2], 1.5, 1e-12);
    }
}

TEST(Vdb, BadInputsAreClearErrors) {
    const std::string dir = tmp_dir("vdb_bad");
    write_vdb(make_volume(ValueType::F32), dir + "/v.vdb");
    VolumeReadOptions o;
    o.grid = "temperature";
    expect_error([&] { read_vdb(dir + "/v.vdb", o); }, ErrorCode::NotFound, {"v.vdb", "temperature", "density"});
    expect_error([&] { read_vdb(dir + "/absent.vdb"); }, ErrorCode::IoError, {"absent.vdb"});
    write_text(dir + "/text.vdb", "not a vdb file at all, just text");
    expect_error([&] { read_vdb(dir + "/text.vdb"); }, ErrorCode::BadMagic, {"text.vdb"});
    auto bytes = read_file_bytes(dir + "/v.vdb");
    // (The library does not need the very last bytes of every file, so only cuts
    // well inside the grid are required to fail.)
    for (std::size_t n : {std::size_t{0}, std::size_t{8}, bytes.size() / 4, bytes.size() / 2, bytes.size() - 64}) {
        write_bytes(dir + "/p.vdb", bytes.data(), n);
        EXPECT_THROW(read_vdb(dir + "/p.vdb"), Error) << "prefix " << n;
    }
}

TEST(Vdb, FailedWriteLeavesNothing) {
    const std::string dir = tmp_dir("vdb_nowrite");
    Volume v = make_volume(ValueType::U8);
    v.spacing = {1, 0, 1};
    expect_error([&] { write_vdb(v, dir + "/out.vdb"); }, ErrorCode::InvalidArgument, {"out.vdb", "spacing"});
    EXPECT_EQ(files_in(dir), 0u);
}
