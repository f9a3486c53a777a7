// Raw volume reader/writer: round trips for every type and byte order, the file
// name convention, and every way a raw file can disagree with what it claims.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "tetlod/converters/raw_volume.hpp"
#include "tetlod/core/error.hpp"

namespace fs = std::filesystem;
using namespace tetlod;

namespace {

std::string tmp(const std::string& name) { return (fs::path(TETLOD_TEST_TMP) / name).string(); }

void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes) {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

std::vector<uint8_t> read_bytes(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// Values that exercise every byte of the type, negative ones for signed types.
Volume pattern_volume(ValueType type, Dims dims) {
    Volume v = Volume::allocate(dims, type);
    for (int64_t i = 0; i < v.count(); ++i) {
        double x = static_cast<double>(i * 37 % 251);
        if (value_size(type) >= 2 && !is_float(type)) x = x * 251.0 + 3.0;
        if (is_signed(type)) x = (i % 2) ? -x / 2.0 : x / 2.0;
        x = std::trunc(x);
        if (is_float(type)) x += 0.25;
        v.set_value(i, x);
    }
    return v;
}

template <class F>
ErrorCode error_of(F&& f, std::string* message = nullptr) {
    try {
        f();
    } catch (const Error& e) {
        if (message) *message = e.what();
        return e.code();
    }
    return ErrorCode::Ok;
}

const ValueType kAllTypes[] = {ValueType::U8,  ValueType::I8,  ValueType::U16, ValueType::I16,
                               ValueType::U32, ValueType::I32, ValueType::F32, ValueType::F64};

}  // namespace

TEST(RawVolume, RoundTripEveryTypeAndEndian) {
    const Dims dims{5, 3, 4};
    for (ValueType type : kAllTypes) {
        for (Endian endian : {Endian::Little, Endian::Big}) {
            SCOPED_TRACE(std::string(value_type_name(type)) +
                         (endian == Endian::Big ? " big" : " little"));
            const Volume v = pattern_volume(type, dims);
            const std::string path = tmp("rt.raw");
            write_raw_volume(v, path, endian);
            EXPECT_EQ(fs::file_size(path), v.bytes());

            VolumeReadOptions o;
            o.dims = dims;
            o.type = type;
            o.endian = endian;
            const Volume r = read_raw_volume(path, o);
            EXPECT_EQ(r.dims, dims);
            EXPECT_EQ(r.type, type);
            EXPECT_EQ(r.data, v.data);
            EXPECT_EQ(r.metadata.at("source_file"), "rt.raw");
        }
    }
}

TEST(RawVolume, BigEndianBytesOnDisk) {
    Volume v = Volume::allocate(Dims{2, 2, 2}, ValueType::U16);
    v.set_value(0, 0x0102);
    const std::string path = tmp("be.raw");
    write_raw_volume(v, path, Endian::Big);
    const auto bytes = read_bytes(path);
    ASSERT_EQ(bytes.size(), 16u);
    EXPECT_EQ(bytes[0], 0x01);
    EXPECT_EQ(bytes[1], 0x02);

    // And a hand-made big-endian i32 file is read as host values.
    write_bytes(tmp("be_i32_2x2x2_i32.raw"),
                std::vector<uint8_t>{0xFF, 0xFF, 0xFF, 0xFE, 0, 0, 1,    0,    0,    0,   0,
                                     0,    0,    0,    0,    0, 0, 0,    0,    0,    0,   0,
                                     0,    0,    0,    0,    0, 0, 0x7F, 0xFF, 0xFF, 0xFF});
    VolumeReadOptions o;
    o.endian = Endian::Big;
    const Volume r = read_raw_volume(tmp("be_i32_2x2x2_i32.raw"), o);
    EXPECT_EQ(r.value(0), -2.0);
    EXPECT_EQ(r.value(1), 256.0);
    EXPECT_EQ(r.value(7), 2147483647.0);
}

TEST(RawVolume, ParsesNameConvention) {
    auto a = parse_raw_volume_name("/some/dir/bucky_32x32x32_uint8.raw");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->dims, (Dims{32, 32, 32}));
    EXPECT_EQ(a->type, ValueType::U8);

    auto b = parse_raw_volume_name("headsq_64x64x93_int16.raw");
    ASSERT_TRUE(b);
    EXPECT_EQ(b->dims, (Dims{64, 64, 93}));
    EXPECT_EQ(b->type, ValueType::I16);

    auto c =
        parse_raw_volume_name("my_big_vol_2X3x4_float32.bin");  // underscores, 'X', any extension
    ASSERT_TRUE(c);
    EXPECT_EQ(c->dims, (Dims{2, 3, 4}));
    EXPECT_EQ(c->type, ValueType::F32);

    for (const char* bad : {"volume.raw", "a_32x32_uint8.raw", "a_32x32x32x2_u8.raw",
                            "a_32x32x32_blah.raw", "a_0x2x2_u8.raw", "a_-1x2x2_u8.raw",
                            "a_x2x2_u8.raw", "32x32x32_u8.raw", "a_3ax2x2_u8.raw"})
        EXPECT_FALSE(parse_raw_volume_name(bad)) << bad;
}

TEST(RawVolume, ReadsDimsAndTypeFromName) {
    const Volume v = pattern_volume(ValueType::I16, Dims{3, 4, 5});
    const std::string path = tmp("vol_3x4x5_int16.raw");
    write_raw_volume(v, path);
    const Volume r = read_raw_volume(path, {});
    EXPECT_EQ(r.dims, (Dims{3, 4, 5}));
    EXPECT_EQ(r.type, ValueType::I16);
    EXPECT_EQ(r.data, v.data);
}

TEST(RawVolume, OptionsWinOverName) {
    const Volume v = pattern_volume(ValueType::U8, Dims{6, 4, 2});
    const std::string path = tmp("other_4x4x3_uint8.raw");  // same byte count, other shape
    write_raw_volume(v, path);
    VolumeReadOptions o;
    o.dims = Dims{6, 4, 2};
    o.spacing = Vec3{0.5, 1.0, 2.0};
    o.origin = Vec3{-1.0, 0.0, 1.0};
    const Volume r = read_raw_volume(path, o);
    EXPECT_EQ(r.dims, (Dims{6, 4, 2}));
    EXPECT_EQ(r.spacing, (Vec3{0.5, 1.0, 2.0}));
    EXPECT_EQ(r.origin, (Vec3{-1.0, 0.0, 1.0}));
    EXPECT_EQ(r.data, v.data);
}

TEST(RawVolume, SkipsHeaderBytes) {
    std::vector<uint8_t> bytes(13, 0xAB);  // junk header
    for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<uint8_t>(i * 10));
    write_bytes(tmp("hdr.raw"), bytes);
    VolumeReadOptions o;
    o.dims = Dims{2, 2, 2};
    o.type = ValueType::U8;
    o.header_bytes = 13;
    const Volume r = read_raw_volume(tmp("hdr.raw"), o);
    for (int i = 0; i < 8; ++i) EXPECT_EQ(r.value(i), i * 10);

    o.header_bytes = 12;  // off by one: the size no longer matches
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("hdr.raw"), o); }), ErrorCode::SizeMismatch);
}

TEST(RawVolume, SizeMismatchNamesFileAndSizes) {
    write_bytes(tmp("short_4x4x4_uint16.raw"), std::vector<uint8_t>(127, 0));
    std::string msg;
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("short_4x4x4_uint16.raw"), {}); }, &msg),
              ErrorCode::SizeMismatch);
    EXPECT_NE(msg.find("short_4x4x4_uint16.raw"), std::string::npos) << msg;
    EXPECT_NE(msg.find("128"), std::string::npos) << msg;
    EXPECT_NE(msg.find("127"), std::string::npos) << msg;

    write_bytes(tmp("long_2x2x2_u8.raw"), std::vector<uint8_t>(9, 0));  // trailing bytes too
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("long_2x2x2_u8.raw"), {}); }),
              ErrorCode::SizeMismatch);
}

TEST(RawVolume, HugeClaimedDimsAreRefusedBeforeAllocating) {
    write_bytes(tmp("tiny.raw"), std::vector<uint8_t>(8, 0));
    VolumeReadOptions o;
    o.type = ValueType::F64;
    o.dims = Dims{2048, 2048, 2048};  // 64 GiB claimed: must fail on size, not on allocation
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("tiny.raw"), o); }), ErrorCode::SizeMismatch);
    o.dims = Dims{int64_t{1} << 20, int64_t{1} << 20, 2};
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("tiny.raw"), o); }), ErrorCode::TooLarge);
    o.header_bytes = UINT64_MAX;  // header + payload overflow
    o.dims = Dims{2, 2, 2};
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("tiny.raw"), o); }), ErrorCode::SizeMismatch);
}

TEST(RawVolume, RefusesSingleSampleAxes) {
    write_bytes(tmp("flat_4x4x1_u8.raw"), std::vector<uint8_t>(16, 0));
    std::string msg;
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("flat_4x4x1_u8.raw"), {}); }, &msg),
              ErrorCode::InvalidArgument);
    EXPECT_NE(msg.find("at least 2"), std::string::npos) << msg;
    VolumeReadOptions o;
    o.dims = Dims{0, 4, 4};
    o.type = ValueType::U8;
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("flat_4x4x1_u8.raw"), o); }),
              ErrorCode::InvalidArgument);
}

TEST(RawVolume, MissingFileAndMissingDims) {
    std::string msg;
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("absent_2x2x2_u8.raw"), {}); }, &msg),
              ErrorCode::IoError);
    EXPECT_NE(msg.find("absent_2x2x2_u8.raw"), std::string::npos) << msg;

    write_bytes(tmp("plain.raw"), std::vector<uint8_t>(8, 0));
    EXPECT_EQ(error_of([&] { read_raw_volume(tmp("plain.raw"), {}); }, &msg),
              ErrorCode::InvalidArgument);
    EXPECT_NE(msg.find("--dims"), std::string::npos) << msg;
}

TEST(RawVolume, SlabBoundariesAreSeamless) {
    // Larger than one 8 MiB slab, with a type whose size divides it: checks that
    // swapping per slab leaves no sample split or skipped.
    const Dims dims{256, 256, 40};  // 2.6 M samples, 10 MiB as u32
    Volume v = Volume::allocate(dims, ValueType::U32);
    for (int64_t i = 0; i < v.count(); ++i)
        v.as<uint32_t>()[i] = static_cast<uint32_t>(i * 2654435761u);
    const std::string path = tmp("slabs.raw");
    write_raw_volume(v, path, Endian::Big);
    VolumeReadOptions o;
    o.dims = dims;
    o.type = ValueType::U32;
    o.endian = Endian::Big;
    EXPECT_EQ(read_raw_volume(path, o).data, v.data);
}

TEST(RawVolume, WriteLeavesNoTemporaryFiles) {
    const std::string dir = tmp("atomic");
    fs::create_directories(dir);
    write_raw_volume(pattern_volume(ValueType::U8, Dims{2, 2, 2}), dir + "/a.raw");
    int files = 0;
    for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
    EXPECT_EQ(files, 1);
}

TEST(RawVolume, ReadsSharedBucky) {
    const std::string path = std::string(TETLOD_SHARED_DATA) + "/bucky_32x32x32_uint8.raw";
    if (!fs::exists(path)) GTEST_SKIP() << "shared dataset absent: " << path;
    const Volume v = read_raw_volume(path, {});
    EXPECT_EQ(v.dims, (Dims{32, 32, 32}));
    EXPECT_EQ(v.type, ValueType::U8);
    EXPECT_EQ(v.bytes(), 32768u);
    EXPECT_EQ(v.metadata.at("source_file"), "bucky_32x32x32_uint8.raw");
    const auto range = v.range();
    EXPECT_LT(range[0], range[1]);  // real data, not a constant
}
