// HDF5 reader/writer: round trips for every type, byte order and compression;
// the real h5py-written copies in the shared data against their raw originals;
// axis order; bad inputs; no time stamped into the bytes.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "format_test_util.hpp"
#include "tetlod/converters/hdf5.hpp"

using namespace tetlod;
using namespace tetlod::test;

TEST(Hdf5, RoundTripEveryTypeByteOrderAndCompression) {
    const std::string dir = tmp_dir("h5_rt");
    for (ValueType t : kAllTypes)
        for (Endian e : {Endian::Little, Endian::Big})
            for (int level : {0, 6}) {
                SCOPED_TRACE(std::string(value_type_name(t)) + (e == Endian::Big ? " big" : " little") + " deflate " +
                             std::to_string(level));
                Volume v = make_volume(t, {7, 5, 3});
                Hdf5WriteOptions o;
                o.endian = e;
                o.deflate_level = level;
                const std::string file = dir + "/v.h5";
                write_hdf5(v, file, "/group/sub/field", o);
                Volume r = read_hdf5(file, "/group/sub/field");
                expect_same_samples(v, r);
                expect_same_geometry(v, r);
                EXPECT_EQ(r.field_name, v.field_name);
                EXPECT_EQ(r.units, v.units);
                for (const auto& [k, val] : v.metadata) EXPECT_EQ(r.metadata[k], val) << k;
                // The only dataset is found without a path.
                Volume d = read_hdf5(file, "");
                expect_same_samples(v, d);
            }
}

TEST(Hdf5, RealH5pyFilesMatchTheirRawOriginals) {
    const char* names[] = {"bucky_32x32x32_uint8",       "bucky_128x128x128_uint8", "neghip_64x64x64_uint8",
                           "iron_protein_68x68x68_uint8", "head_mr_48x62x42_uint8",  "headsq_64x64x93_int16",
                           "m4_total_density_25x22x31_float32"};
    int checked = 0;
    for (const char* n : names) {
        const std::string h5 = data_path(std::string(n) + ".h5"), raw = data_path(std::string(n) + ".raw");
        if (!std::filesystem::exists(h5) || !std::filesystem::exists(raw)) continue;
        SCOPED_TRACE(n);
        Volume v = read_hdf5(h5, "/volume");
        auto bytes = read_file_bytes(raw);
        ASSERT_EQ(bytes.size(), v.data.size());
        EXPECT_TRUE(std::memcmp(bytes.data(), v.data.data(), bytes.size()) == 0);
        EXPECT_EQ(v.metadata.count("description"), 1u);
        ++checked;
    }
    if (checked == 0) GTEST_SKIP() << "shared .h5 data absent";
    const std::string hs = data_path("headsq_64x64x93_int16.h5");
    if (std::filesystem::exists(hs)) {
        Volume v = read_hdf5(hs, "volume");
        EXPECT_EQ(v.dims, (Dims{64, 64, 93}));
        EXPECT_EQ(v.type, ValueType::I16);
        EXPECT_EQ(v.spacing, (Vec3{3.2, 3.2, 1.5}));
    }
}

TEST(Hdf5, AxisOrderXyzTransposes) {
    const std::string dir = tmp_dir("h5_axis");
    // Written as (Z,Y,X) = (3,5,7); read as xyz the same file is a 3x5x7 volume
    // whose sample (i,j,k) is the written sample at x=k, y=j, z=i.
    Volume v = make_volume(ValueType::I32, {7, 5, 3});
    v.metadata.clear();
    write_hdf5(v, dir + "/a.h5", "/volume");
    VolumeReadOptions o;
    o.axis_order = "xyz";
    // dims_xyz written for zyx no longer fits: a clear size mismatch.
    expect_error([&] { read_hdf5(dir + "/a.h5", "/volume", o); }, ErrorCode::SizeMismatch, {"a.h5", "dims_xyz"});
    v.metadata["note"] = "x";
    // Without dims_xyz (write via a volume whose reader ignores it is not possible),
    // check the transpose on a file with the attribute removed by rewriting: use
    // a 1-D-per-axis volume where dims_xyz happens to agree (cube).
    Volume c = make_volume(ValueType::I32, {4, 4, 4});
    for (int64_t i = 0; i < c.count(); ++i) c.as<int32_t>()[i] = static_cast<int32_t>(i);
    write_hdf5(c, dir + "/c.h5", "/volume");
    Volume t = read_hdf5(dir + "/c.h5", "/volume", o);
    for (int64_t k = 0; k < 4; ++k)
        for (int64_t j = 0; j < 4; ++j)
            for (int64_t i = 0; i < 4; ++i) EXPECT_EQ(t.value(i, j, k), c.value(k, j, i));
    o.axis_order = "yxz";
    expect_error([&] { read_hdf5(dir + "/c.h5", "/volume", o); }, ErrorCode::InvalidArgument, {"c.h5", "yxz"});
}

TEST(Hdf5, BadInputsAreClearErrors) {
    const std::string dir = tmp_dir("h5_bad");
    write_hdf5(make_volume(ValueType::U8), dir + "/v.h5", "/volume");
    expect_error([&] { read_hdf5(dir + "/v.h5", "/nope/deeper"); }, ErrorCode::NotFound,
                 {"v.h5", "/nope/deeper", "/volume"});
    expect_error([&] { read_hdf5(dir + "/v.h5", "/volumes"); }, ErrorCode::NotFound, {"v.h5", "/volumes"});
    expect_error([&] { read_hdf5(dir + "/absent.h5", "/volume"); }, ErrorCode::IoError, {"absent.h5"});
    write_text(dir + "/text.h5", "this is not HDF5");
    expect_error([&] { read_hdf5(dir + "/text.h5", "/volume"); }, ErrorCode::BadMagic, {"text.h5"});
    // Truncated: the contiguous dataset runs past the end of the file.
    Volume big = make_volume(ValueType::F64, {64, 64, 8});
    big.metadata.clear();
    write_hdf5(big, dir + "/t.h5", "/volume");
    auto bytes = read_file_bytes(dir + "/t.h5");
    write_bytes(dir + "/t.h5", bytes.data(), bytes.size() - 4096);
    EXPECT_THROW(read_hdf5(dir + "/t.h5", "/volume"), Error);
}

TEST(Hdf5, FailedWriteLeavesNothing) {
    const std::string dir = tmp_dir("h5_nowrite");
    Volume v = make_volume(ValueType::U8);
    v.data.resize(v.data.size() - 1);  // (an empty metadata key is left out, not refused)
    expect_error([&] { write_hdf5(v, dir + "/out.h5", "/volume"); }, ErrorCode::InvalidArgument, {"out.h5"});
    EXPECT_EQ(files_in(dir), 0u);
    v = make_volume(ValueType::U8);
    expect_error([&] { write_hdf5(v, dir + "/no/such/dir/out.h5", "/volume"); }, ErrorCode::IoError, {"out.h5"});
    EXPECT_EQ(files_in(dir), 0u);
}

// No time is stamped into the file: the same volume written a second later, to a
// new file, gives the same bytes (contiguous and deflated, parent groups created).
TEST(Hdf5, SameVolumeGivesTheSameBytes) {
    const std::string dir = tmp_dir("h5_repro");
    const Volume v = make_volume(ValueType::F32, {9, 6, 4});
    auto write_all = [&](const std::string& stem) {
        Hdf5WriteOptions deflated;
        deflated.deflate_level = 6;
        write_hdf5(v, dir + "/" + stem + "_plain.h5", "/volume");
        write_hdf5(v, dir + "/" + stem + "_deflated.h5", "/x/y/field", deflated);
        write_hdf5(v, dir + "/" + stem + "_deflated.h5", "/x/z/again");  // an update adds a group
    };
    write_all("first");
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // a different second
    write_all("second");
    for (const char* which : {"_plain.h5", "_deflated.h5"}) {
        SCOPED_TRACE(which);
        const std::string first = slurp(dir + "/first" + which);
        ASSERT_FALSE(first.empty());
        EXPECT_TRUE(first == slurp(dir + "/second" + which)) << "the two writes differ";
    }
}
