// HDF5 plane by plane: open_hdf5_planes gives read_hdf5's header and samples
// for every type, byte order, layout (contiguous; chunked one plane deep and
// chunks spanning several planes, deflated), axis order (zyx, xyz) and rank,
// in forward, backward and shuffled order, isolated or not; write_hdf5 fed
// planes writes the whole writer's bytes and keeps an existing file's other
// datasets; a truncated file, a corrupt file and a child that dies are clean
// errors naming the file.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cstring>

#include "format_test_util.hpp"
#include "support/plane_checks.hpp"
#include "tetlod/converters/hdf5.hpp"

using namespace tetlod;
using namespace tetlod::test;

namespace {

void check_file(const std::string& file, const std::string& dataset,
                const VolumeReadOptions& o = {}) {
    const Volume whole = read_hdf5(file, dataset, o);
    for (bool isolated : {true, false}) {
        SCOPED_TRACE(isolated ? "isolated" : "in process");
        VolumeReadOptions p = o;
        p.isolation.enabled = isolated;
        auto planes = open_hdf5_planes(file, dataset, p);
        expect_planes_equal_whole(*planes, whole, 11);
    }
}

// A dataset written with the library itself: shape `shape` (rank 1..3), i32
// values i * 7 - 1000, chunked `chunk` (empty: contiguous) and deflated.
void write_raw_dataset(const std::string& file, std::vector<hsize_t> shape,
                       std::vector<hsize_t> chunk, const char* axis_order) {
    hid_t f = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    hid_t s = H5Screate_simple(int(shape.size()), shape.data(), nullptr);
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    if (!chunk.empty()) {
        H5Pset_chunk(dcpl, int(chunk.size()), chunk.data());
        H5Pset_deflate(dcpl, 4);
    }
    hid_t d = H5Dcreate2(f, "/v", H5T_STD_I32BE, s, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    hsize_t n = 1;
    for (hsize_t e : shape) n *= e;
    std::vector<int32_t> values(n);
    for (hsize_t i = 0; i < n; ++i) values[i] = int32_t(i * 7) - 1000;
    H5Dwrite(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    if (axis_order) {
        hid_t t = H5Tcopy(H5T_C_S1);
        H5Tset_size(t, std::strlen(axis_order));
        hid_t as = H5Screate(H5S_SCALAR);
        hid_t a = H5Acreate2(d, "axis_order", t, as, H5P_DEFAULT, H5P_DEFAULT);
        H5Awrite(a, t, axis_order);
        H5Aclose(a);
        H5Sclose(as);
        H5Tclose(t);
    }
    H5Dclose(d);
    H5Pclose(dcpl);
    H5Sclose(s);
    H5Fclose(f);
}

}  // namespace

TEST(Hdf5Planes, EveryTypeByteOrderAndCompressionEqualsTheWholeRead) {
    const std::string dir = tmp_dir("h5_planes_rt");
    for (ValueType t : kAllTypes)
        for (Endian e : {Endian::Little, Endian::Big})
            for (int level : {0, 6}) {
                SCOPED_TRACE(std::string(value_type_name(t)) +
                             (e == Endian::Big ? " big" : " little") + " deflate " +
                             std::to_string(level));
                Volume v = make_volume(t, {9, 6, 11});
                v.spacing = {0.5, 0.25, 2};
                v.origin = {1, -2, 3};
                Hdf5WriteOptions o;
                o.endian = e;
                o.deflate_level = level;
                write_hdf5(v, dir + "/v.h5", "/group/field", o);
                check_file(dir + "/v.h5", "/group/field");
            }
}

TEST(Hdf5Planes, ChunksAcrossPlanesAxisOrdersAndRanks) {
    const std::string dir = tmp_dir("h5_planes_layouts");
    struct Layout {
        std::vector<hsize_t> shape, chunk;
        const char* axis_order;
    };
    const Layout layouts[] = {
        {{23, 17, 19}, {8, 5, 7}, nullptr},  // chunks spanning 8 planes, partial at the edges
        {{23, 17, 19}, {}, "xyz"},           // contiguous [x][y][z]
        {{23, 17, 19}, {4, 17, 6}, "xyz"},   // chunked [x][y][z]
        {{40, 30}, {7, 9}, nullptr},         // rank 2: one plane
        {{40, 30}, {}, "xyz"},               // rank 2 transposed
        {{50}, {16}, nullptr},               // rank 1
    };
    int i = 0;
    for (const Layout& l : layouts) {
        SCOPED_TRACE(i);
        const std::string file = dir + "/l" + std::to_string(i++) + ".h5";
        write_raw_dataset(file, l.shape, l.chunk, l.axis_order);
        check_file(file, "/v");
    }
    // The option overrides the attribute, as in the whole read.
    write_raw_dataset(dir + "/o.h5", {12, 13, 14}, {5, 5, 5}, nullptr);
    VolumeReadOptions o;
    o.axis_order = "xyz";
    check_file(dir + "/o.h5", "/v", o);
}

TEST(Hdf5Planes, SharedDataFilesEqualTheirWholeReads) {
    int checked = 0;
    for (const char* n :
         {"headsq_64x64x93_int16", "m4_total_density_25x22x31_float32", "bucky_32x32x32_uint8"}) {
        const std::string h5 = data_path(std::string(n) + ".h5");
        if (!std::filesystem::exists(h5)) continue;
        SCOPED_TRACE(n);
        check_file(h5, "/volume");
        ++checked;
    }
    if (checked == 0) GTEST_SKIP() << "shared .h5 data absent";
}

TEST(Hdf5Planes, WriterFedPlanesWritesTheWholeWritersBytes) {
    const std::string dir = tmp_dir("h5_planes_write");
    int compared = 0;
    for (int level : {0, 6})
        for (Dims d : {Dims{9, 6, 11},
                       Dims{1500, 1500, 3}}) {  // several planes per batch; a plane past 16 MiB / 8
            SCOPED_TRACE(std::to_string(level) + " " + std::to_string(d.x));
            Volume v = make_volume(ValueType::F64, d);
            v.metadata["who"] = "test";
            Hdf5WriteOptions o;
            o.deflate_level = level;
            std::filesystem::remove(dir + "/whole.h5");  // new files, not updates
            std::filesystem::remove(dir + "/planes.h5");
            write_hdf5(v, dir + "/whole.h5", "/a/v", o);
            auto planes = planes_of(v);
            write_hdf5(*planes, dir + "/planes.h5", "/a/v", o);
            // Contiguous (the CLI's layout): the same bytes (no time is stamped
            // in them). Chunked: the same chunks, which the library may place
            // in another order.
            if (level == 0) {
                EXPECT_TRUE(slurp(dir + "/whole.h5") == slurp(dir + "/planes.h5"));
                ++compared;
            }
            const Volume back = read_hdf5(dir + "/planes.h5", "/a/v");
            EXPECT_TRUE(back.data == v.data);
            EXPECT_EQ(back.metadata, read_hdf5(dir + "/whole.h5", "/a/v").metadata);
        }
    EXPECT_EQ(compared, 2);
    // Into an existing file: its other dataset stays, as with the whole writer.
    Volume a = make_volume(ValueType::U16, {5, 4, 3}), b = make_volume(ValueType::I8, {7, 3, 9});
    write_hdf5(a, dir + "/two.h5", "/first");
    auto planes = planes_of(b);
    write_hdf5(*planes, dir + "/two.h5", "/second");
    expect_same_samples(a, read_hdf5(dir + "/two.h5", "/first"));
    expect_same_samples(b, read_hdf5(dir + "/two.h5", "/second"));
    // Planes that fail mid-way leave the target as it was.
    FailingPlanes failing(make_volume(ValueType::U8, {3000, 3000, 4}), 0);  // 9 MB planes: one per batch
    const std::string before = slurp(dir + "/two.h5");
    EXPECT_THROW(write_hdf5(failing, dir + "/two.h5", "/third"), Error);
    EXPECT_TRUE(slurp(dir + "/two.h5") == before);
}

TEST(Hdf5Planes, TruncatedAndCorruptFilesAreCleanErrors) {
    const std::string dir = tmp_dir("h5_planes_bad");
    Volume big = make_volume(ValueType::F64, {64, 64, 8});
    big.metadata.clear();
    write_hdf5(big, dir + "/t.h5", "/volume");
    const std::string bytes = slurp(dir + "/t.h5");
    spit(dir + "/t.h5", bytes.substr(0, bytes.size() - 4096));
    for (bool isolated : {true, false}) {
        VolumeReadOptions o;
        o.isolation.enabled = isolated;
        // The library itself refuses a file shorter than its superblock says
        // (IoError, as for the whole read); tetlod's check catches the rest.
        try {
            open_hdf5_planes(dir + "/t.h5", "/volume", o);
            ADD_FAILURE() << "a truncated file was opened";
        } catch (const Error& e) {
            EXPECT_TRUE(e.code() == ErrorCode::Truncated || e.code() == ErrorCode::IoError)
                << e.what();
            EXPECT_NE(std::string(e.what()).find("t.h5"), std::string::npos) << e.what();
        }
    }
    expect_error([&] { open_hdf5_planes(dir + "/none.h5", "/volume"); }, ErrorCode::IoError,
                 {"none.h5"});
    write_hdf5(big, dir + "/g.h5", "/volume");
    expect_error([&] { open_hdf5_planes(dir + "/g.h5", "/nope"); }, ErrorCode::NotFound,
                 {"g.h5", "/nope"});

    // Deflated chunks spanning planes, with bits flipped through the file:
    // every plane read is a result or a tetlod::Error, never a crash of ours.
    write_raw_dataset(dir + "/c.h5", {16, 16, 16}, {4, 8, 8}, nullptr);
    const std::string good = slurp(dir + "/c.h5");
    VolumeReadOptions o;
    o.isolation.timeout_seconds = 3;
    int errors = 0, reads = 0;
    std::vector<std::byte> buf(16 * 16 * 4);
    for (std::size_t pos = good.size() / 3; pos < good.size(); pos += good.size() / 60) {
        std::string m = good;
        m[pos] = char(m[pos] ^ 0x24);
        spit(dir + "/f.h5", m);
        try {
            auto planes = open_hdf5_planes(dir + "/f.h5", "/v", o);
            for (int64_t z = 0; z < planes->header().dims.z; ++z) planes->read(z, 1, buf.data());
            ++reads;
        } catch (const Error& e) {
            ++errors;
            EXPECT_NE(std::string(e.what()).find("f.h5"), std::string::npos) << e.what();
        }
    }
    EXPECT_GT(reads + errors, 30);
}
