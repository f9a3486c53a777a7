// Volumes plane by plane, as a third party uses them: a container read back
// plane by plane (open_container_planes) gives the samples of the whole decode
// for any order of reads, any cache, including one that keeps nothing, and 1
// or 2 threads (chunks decode in parallel);
// writers fed planes write the bytes of writing the whole volume; a raw file
// read by offset gives its samples; a corrupt chunk met while reading planes
// is an error naming the container, and the output is not left behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "support/plane_checks.hpp"
#include "tetlod/tetlod.hpp"

namespace {

namespace fs = std::filesystem;
using namespace tetlod;

std::string tmp(const std::string& name) { return std::string(TETLOD_TEST_TMP) + "/planes_" + name; }

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

struct Case {
    Dims dims;
    ValueType type;
    bool pad;
    int brick_log2;
};

std::vector<Case> cases() {
    return {{{2, 2, 2}, ValueType::U8, false, 4},       {{19, 3, 40}, ValueType::I16, false, 1},
            {{33, 17, 70}, ValueType::F32, true, 2},    {{70, 41, 66}, ValueType::U8, false, 1},
            {{40, 45, 37}, ValueType::F64, false, 4},   {{36, 35, 34}, ValueType::U32, true, 1}};
}

std::string name_of(const Case& c) {
    return std::to_string(c.dims.x) + "x" + std::to_string(c.dims.y) + "x" + std::to_string(c.dims.z) + " " +
           value_type_name(c.type) + (c.pad ? " padded" : "") + " g" + std::to_string(c.brick_log2);
}

}  // namespace

TEST(VolumePlanes, ContainerPlanesEqualTheWholeDecodeInAnyOrderAndCache) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(name_of(c));
        Volume v = make_sample_volume("multiscale", c.dims, c.type);
        v.metadata["who"] = "test";
        const std::string path = tmp("c.tlod");
        ContainerWriteOptions o;
        o.pad = c.pad;
        o.brick_log2 = c.brick_log2;
        o.zstd_level = 3;
        write_container(Volume(v), path, o);
        for (int threads : {1, 2}) {
        SCOPED_TRACE("threads " + std::to_string(threads));
        const ThreadLimit limit(threads);
        const Volume whole = decode_container(path).take();
        ASSERT_TRUE(whole.data == v.data);
        const auto orders = tetlod::test::plane_orders(c.dims.z, 7);
        const char* const kOrderNames[] = {"forward", "backward", "shuffled"};
        for (std::size_t cache : {std::size_t{0}, std::size_t{1}}) {  // what a row needs; nothing kept
            for (std::size_t how = 0; how < orders.size(); ++how) {
                auto planes = open_container_planes(path, cache).take();
                EXPECT_EQ(planes->header().dims, c.dims);
                EXPECT_EQ(planes->header().type, c.type);
                EXPECT_EQ(planes->header().spacing, whole.spacing);
                EXPECT_EQ(planes->header().metadata, whole.metadata);
                const auto got = tetlod::test::read_planes_in(*planes, orders[how]);
                EXPECT_TRUE(got.size() == whole.data.size() &&
                            std::equal(got.begin(), got.end(), whole.data.begin()))
                    << "cache " << cache << " order " << kOrderNames[how];
            }
            // Several planes in one read, across rows of bricks.
            auto planes = open_container_planes(path, cache).take();
            std::vector<std::byte> all(whole.data.size());
            planes->read(0, c.dims.z, all.data());
            EXPECT_TRUE(std::equal(all.begin(), all.end(), whole.data.begin()));
        }
        }
    }
}

TEST(VolumePlanes, WritersFedPlanesWriteTheWholeVolumesBytes) {
    Volume v = make_sample_volume("multiscale", Dims{23, 31, 37}, ValueType::I16);
    v.metadata["patient"] = "anon";
    v.spacing = {0.5, 0.25, 2};
    for (const char* ext : {"raw", "nrrd", "nhdr", "mha", "mhd", "h5"}) {
        SCOPED_TRACE(ext);
        if (std::string(ext) == "h5" && !volume_format_built("h5")) continue;
        const std::string a = tmp(std::string("whole.") + ext), b = tmp(std::string("planes.") + ext);
        // HDF5: new files (an existing one is updated in place).
        fs::remove(a);
        fs::remove(b);
        write_volume(v, a);
        auto planes = planes_of(v);
        write_volume(*planes, b);
        EXPECT_EQ(volume_format_writes_planes(b), true);
        std::string sa = slurp(a), sb = slurp(b);
        // Detached headers name their own data file.
        if (std::string(ext) == "nhdr" || std::string(ext) == "mhd") {
            EXPECT_EQ(slurp(tmp("whole.raw")).size(), slurp(tmp("planes.raw")).size());
            for (auto* s : {&sa, &sb}) {
                const auto at = s->find(std::string(ext) == "nhdr" ? "data file:" : "ElementDataFile");
                ASSERT_NE(at, std::string::npos);
                s->resize(at);
            }
        }
        EXPECT_EQ(sa, sb);
    }
}

TEST(VolumePlanes, RawFilesAreReadByOffset) {
    const Volume v = make_sample_volume("multiscale", Dims{17, 9, 21}, ValueType::F32);
    const std::string path = tmp("r_17x9x21_float32.raw");
    write_volume(v, path);
    auto planes = open_volume_planes(path);
    ASSERT_TRUE(planes);
    EXPECT_EQ(planes->header().dims, v.dims);
    const std::size_t plane = std::size_t(17 * 9) * 4;
    std::vector<std::byte> got(plane * 3);
    planes->read(5, 3, got.data());
    EXPECT_TRUE(std::equal(got.begin(), got.end(), v.data.begin() + std::ptrdiff_t(5 * plane)));
    EXPECT_THROW(planes->read(20, 2, got.data()), Error);  // past the last plane
    // NRRD and MetaImage with one uncompressed data block, attached or
    // detached, by offset too; compressed ones as a stream (test_nrrd_planes
    // covers every layout).
    NrrdWriteOptions gz;
    gz.gzip = true;
    write_nrrd(v, tmp("gz.nrrd"), gz);
    MetaImageWriteOptions packed;
    packed.compress = true;
    write_metaimage(v, tmp("z.mha"), packed);
    MetaImageWriteOptions plain;
    plain.compress = false;
    write_metaimage(v, tmp("p.mha"), plain);
    write_metaimage(v, tmp("p.mhd"), plain);
    NrrdWriteOptions be;
    be.endian = Endian::Big;
    write_nrrd(v, tmp("be.nrrd"), be);
    for (const char* name : {"p.mha", "p.mhd", "be.nrrd", "a.nhdr", "gz.nrrd", "z.mha"}) {
        SCOPED_TRACE(name);
        if (std::string(name) == "a.nhdr") write_volume(v, tmp(name));
        auto p = open_volume_planes(tmp(name));
        ASSERT_TRUE(p);
        const Volume whole = read_volume(tmp(name));
        EXPECT_EQ(p->header().spacing, whole.spacing);
        EXPECT_EQ(p->header().metadata, whole.metadata);
        std::vector<std::byte> all(whole.data.size());
        p->read(0, v.dims.z, all.data());
        EXPECT_TRUE(std::equal(all.begin(), all.end(), whole.data.begin()));
    }
}

TEST(VolumePlanes, CorruptChunkIsAnErrorNamingTheContainer) {
    const Volume v = make_sample_volume("multiscale", Dims{40, 40, 40}, ValueType::U8);
    const std::string path = tmp("bad.tlod");
    ContainerWriteOptions o;
    o.zstd_level = 3;
    o.brick_log2 = 4;  // the layout the byte below is chosen for (automatic: 5 here)
    write_container(Volume(v), path, o);
    // Flip a byte near the end: inside the finest cycle's last chunks.
    std::string bytes = slurp(path);
    bytes[bytes.size() - 40] = char(bytes[bytes.size() - 40] ^ 0x5a);
    std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    auto planes = open_container_planes(path).take();
    const std::string out = tmp("bad_out.raw");
    fs::remove(out);
    try {
        write_volume(*planes, out);
        FAIL() << "a corrupt chunk was decoded";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(out));
}

// brick_log2 0 (the default) is settled from the volume's longest axis, the
// same way by the whole and the plane-by-plane writers; an explicit size stays.
TEST(VolumePlanes, AutomaticBrickSizeFollowsTheLongestAxisOnEveryWritePath) {
    struct Case {
        Dims dims;
        int given, expected;
    };
    for (const Case& c : {Case{{129, 20, 9}, 0, 5}, Case{{9, 130, 9}, 0, 4}, Case{{20, 20, 20}, 3, 3},
                          Case{{9, 9, 131}, 5, 5}}) {
        SCOPED_TRACE(std::to_string(c.dims.x) + "x" + std::to_string(c.dims.y) + "x" + std::to_string(c.dims.z));
        EXPECT_EQ(auto_brick_log2(c.dims), std::max({c.dims.x, c.dims.y, c.dims.z}) <= 129 ? 5 : 4);
        const Volume v = make_sample_volume("multiscale", c.dims, ValueType::U8);
        ContainerWriteOptions o;
        o.brick_log2 = c.given;
        o.created = 0;
        o.zstd_level = 3;
        const std::string whole = tmp("auto_whole.tlod"), streamed = tmp("auto_planes.tlod");
        write_container(Volume(v), whole, o);
        auto planes = planes_of(v);
        write_container(*planes, streamed, o);
        EXPECT_EQ(slurp(whole), slurp(streamed));
        const ContainerInfo info = inspect_container(whole).take();
        ASSERT_TRUE(info.ht.has_value());
        EXPECT_EQ(info.ht->brick_log2, c.expected);
    }
    ContainerWriteOptions bad;
    bad.brick_log2 = 17;
    EXPECT_THROW(write_container(make_sample_volume("multiscale", Dims{5, 5, 5}, ValueType::U8), tmp("bad_g.tlod"), bad),
                 Error);
}
