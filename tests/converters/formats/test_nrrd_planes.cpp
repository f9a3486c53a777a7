// NRRD and MetaImage plane by plane in every layout the whole reader takes:
// gzip (attached, detached, with line and byte skips, concatenated members),
// zlib, several data files (one or two planes each, by pattern or list, raw or
// gzip). Planes read forward, backward, shuffled, all at once and in batches
// equal the whole read; a truncated or corrupt stream and a missing or
// external data file are clean errors naming the file.
#include <gtest/gtest.h>
#include <zlib.h>

#include <random>

#include "format_test_util.hpp"
#include "support/plane_checks.hpp"
#include "tetlod/converters/metaimage.hpp"
#include "tetlod/converters/nrrd.hpp"

using namespace tetlod;
using namespace tetlod::test;

namespace {

constexpr int64_t X = 13, Y = 7, Z = 10;

// Samples i * 37 - 2000 as int16 in `big`-endian order, planes z0 .. z0 + n - 1.
std::string samples(int64_t z0, int64_t n, bool big = false) {
    std::string out;
    for (int64_t i = z0 * X * Y; i < (z0 + n) * X * Y; ++i) {
        const auto v = static_cast<uint16_t>(int16_t(i * 37 - 2000));
        const char lo = char(v & 0xff), hi = char(v >> 8);
        out += big ? std::string{hi, lo} : std::string{lo, hi};
    }
    return out;
}

std::string deflate_bytes(const std::string& in, bool gzip) {
    z_stream zs{};
    deflateInit2(&zs, 6, Z_DEFLATED, gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY);
    std::string out(deflateBound(&zs, uLong(in.size())), '\0');
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
    zs.avail_in = uInt(in.size());
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = uInt(out.size());
    EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
    out.resize(zs.total_out);
    deflateEnd(&zs);
    return out;
}

const std::string kHead = "NRRD0004\ntype: short\ndimension: 3\nsizes: 13 7 10\n";

void check(const std::string& path) {
    SCOPED_TRACE(path);
    const bool mha = path.find(".mh") != std::string::npos;
    const Volume whole = mha ? read_metaimage(path) : read_nrrd(path);
    auto planes = mha ? open_metaimage_planes(path, {}) : open_nrrd_planes(path, {});
    ASSERT_TRUE(planes);
    expect_planes_equal_whole(*planes, whole, 5);
}

}  // namespace

TEST(NrrdPlanes, GzipAndZlibStreams) {
    const std::string dir = tmp_dir("nrrd_planes_gz");
    Volume v = read_nrrd([&] {
        write_text(dir + "/src.raw", samples(0, Z));
        write_text(dir + "/src.nhdr",
                   kHead + "encoding: raw\nendian: little\ndata file: src.raw\n");
        return dir + "/src.nhdr";
    }());
    v.metadata["k"] = "v";
    NrrdWriteOptions gz;
    gz.gzip = true;
    write_nrrd(v, dir + "/a.nrrd", gz);
    check(dir + "/a.nrrd");
    // Detached, big endian, two lines skipped before the stream and 5 bytes
    // skipped inside it.
    write_text(dir + "/d.gz", "one\ntwo\n" + deflate_bytes("12345" + samples(0, Z, true), true));
    write_text(
        dir + "/d.nhdr",
        kHead + "encoding: gzip\nendian: big\nline skip: 2\nbyte skip: 5\ndata file: d.gz\n");
    check(dir + "/d.nhdr");
    // Two concatenated gzip members.
    write_text(dir + "/m.gz",
               deflate_bytes(samples(0, 4), true) + deflate_bytes(samples(4, Z - 4), true));
    write_text(dir + "/m.nhdr", kHead + "encoding: gzip\nendian: little\ndata file: m.gz\n");
    check(dir + "/m.nhdr");
    // MetaImage: zlib, attached and detached.
    MetaImageWriteOptions packed;
    packed.compress = true;
    write_metaimage(v, dir + "/z.mha", packed);
    check(dir + "/z.mha");
    write_metaimage(v, dir + "/z.mhd", packed);
    check(dir + "/z.mhd");
}

TEST(NrrdPlanes, SeveralDataFiles) {
    const std::string dir = tmp_dir("nrrd_planes_multi");
    for (int64_t z = 0; z < Z; ++z) {
        write_text(dir + "/s" + std::to_string(z + 1) + ".raw", samples(z, 1));  // headsq's layout
        write_text(dir + "/l" + std::to_string(z + 1) + ".raw", "skip me\n" + samples(z, 1));
    }
    for (int64_t k = 0; k < Z / 2; ++k) {
        write_text(dir + "/p" + std::to_string(k) + ".raw", samples(2 * k, 2));
        write_text(dir + "/p" + std::to_string(k) + ".gz", deflate_bytes(samples(2 * k, 2), true));
    }
    write_text(dir + "/slices.nhdr",
               kHead + "encoding: raw\nendian: little\ndata file: s%d.raw 1 10 1\n");
    check(dir + "/slices.nhdr");
    write_text(dir + "/skips.nhdr",
               kHead + "encoding: raw\nendian: little\nline skip: 1\ndata file: l%d.raw 1 10 1\n");
    check(dir + "/skips.nhdr");
    write_text(dir + "/pairs.nhdr", kHead +
                                        "encoding: raw\nendian: little\ndata file: "
                                        "LIST\np0.raw\np1.raw\np2.raw\np3.raw\np4.raw\n");
    check(dir + "/pairs.nhdr");
    write_text(dir + "/gz.nhdr",
               kHead + "encoding: gzip\nendian: little\ndata file: p%d.gz 0 4 1\n");
    check(dir + "/gz.nhdr");
}

TEST(NrrdPlanes, BadStreamsAndFilesAreCleanErrors) {
    const std::string dir = tmp_dir("nrrd_planes_bad");
    const std::string gz = deflate_bytes(samples(0, Z), true);
    // Truncated: the planes that exist are read, the rest is an error naming the file.
    write_text(dir + "/t.gz", gz.substr(0, gz.size() / 2));
    write_text(dir + "/t.nhdr", kHead + "encoding: gzip\nendian: little\ndata file: t.gz\n");
    auto planes = open_nrrd_planes(dir + "/t.nhdr", {});
    std::vector<std::byte> buf(std::size_t(X * Y * Z) * 2);
    expect_error([&] { planes->read(0, Z, buf.data()); }, ErrorCode::Truncated, {"t.gz"});
    // Cut inside the trailer: every sample is there, the checksum is not.
    write_text(dir + "/c.gz", gz.substr(0, gz.size() - 3));
    write_text(dir + "/c.nhdr", kHead + "encoding: gzip\nendian: little\ndata file: c.gz\n");
    planes = open_nrrd_planes(dir + "/c.nhdr", {});
    expect_error([&] { planes->read(0, Z, buf.data()); }, ErrorCode::Truncated, {"c.gz"});
    // Corrupt: a flipped byte in the stream (bad data or a checksum mismatch).
    std::string bad = gz;
    bad[bad.size() / 2] = char(bad[bad.size() / 2] ^ 0x55);
    write_text(dir + "/b.gz", bad);
    write_text(dir + "/b.nhdr", kHead + "encoding: gzip\nendian: little\ndata file: b.gz\n");
    planes = open_nrrd_planes(dir + "/b.nhdr", {});
    try {
        for (int64_t z = 0; z < Z; ++z) planes->read(z, 1, buf.data());
        ADD_FAILURE() << "a corrupt stream was read";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("b.gz"), std::string::npos) << e.what();
    }
    // A missing slice, a short slice, a data file outside the header's folder.
    for (int64_t z = 0; z < Z; ++z)
        write_text(dir + "/s" + std::to_string(z + 1) + ".raw", samples(z, 1));
    write_text(dir + "/s4.raw", samples(3, 1).substr(1));
    write_text(dir + "/short.nhdr",
               kHead + "encoding: raw\nendian: little\ndata file: s%d.raw 1 10 1\n");
    expect_error([&] { open_nrrd_planes(dir + "/short.nhdr", {}); }, ErrorCode::Truncated,
                 {"s4.raw"});
    write_text(dir + "/gap.nhdr",
               kHead + "encoding: raw\nendian: little\ndata file: s%d.raw 1 11 1\n");
    EXPECT_THROW(open_nrrd_planes(dir + "/gap.nhdr", {}), Error);
    std::filesystem::create_directories(dir + "/sub");
    write_text(dir + "/sub/out.nhdr",
               kHead + "encoding: gzip\nendian: little\ndata file: ../t.gz\n");
    expect_error([&] { open_nrrd_planes(dir + "/sub/out.nhdr", {}); },
                 ErrorCode::UnsupportedFeature, {"t.gz"});
    VolumeReadOptions allow;
    allow.allow_external_data = true;
    EXPECT_TRUE(open_nrrd_planes(dir + "/sub/out.nhdr", allow));
}

// A header claiming a large volume over a garbage, cut or short compressed stream
// fails when the planes are opened (the first plane is inflated there), naming
// the data file, before a caller has planned any buffer from the claimed dims.
TEST(NrrdPlanes, GarbageStreamsFailAtOpen) {
    const std::string dir = tmp_dir("nrrd_planes_open");
    std::mt19937 rng(11);
    std::string junk(1100000, '\0');  // enough bytes for the deflate bound of 1 GiB
    for (char& c : junk) c = char(rng());
    const std::string big = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1024 1024 1024\n";
    // gzip magic then garbage, attached.
    std::string gz = junk;
    gz[0] = char(0x1f), gz[1] = char(0x8b), gz[2] = 8, gz[3] = 0;
    write_text(dir + "/g.nrrd", big + "encoding: gzip\n\n" + gz);
    expect_error([&] { open_nrrd_planes(dir + "/g.nrrd", {}); }, ErrorCode::CorruptData,
                 {"g.nrrd", "corrupt"});
    // A valid gzip header over a garbage deflate stream, detached.
    const std::string head = deflate_bytes("", true).substr(0, 10);
    write_text(dir + "/h.gz", head + junk);
    write_text(dir + "/h.nhdr", big + "encoding: gzip\ndata file: h.gz\n");
    expect_error([&] { open_nrrd_planes(dir + "/h.nhdr", {}); }, ErrorCode::CorruptData,
                 {"h.gz", "corrupt"});
    // MetaImage, zlib magic then garbage in a detached data file.
    std::string z = junk;
    z[0] = char(0x78), z[1] = char(0x9c);
    write_text(dir + "/z.zraw", z);
    write_text(dir + "/z.mhd",
               "ObjectType = Image\nNDims = 3\nDimSize = 1024 1024 1024\nElementType = MET_UCHAR\n"
               "CompressedData = True\nElementDataFile = z.zraw\n");
    expect_error([&] { open_metaimage_planes(dir + "/z.mhd", {}); }, ErrorCode::CorruptData,
                 {"z.zraw", "corrupt"});
    // Not a deflate stream at all.
    write_text(dir + "/t.gz", std::string(2000, 'x'));
    write_text(dir + "/t.nhdr", kHead + "encoding: gzip\nendian: little\ndata file: t.gz\n");
    expect_error([&] { open_nrrd_planes(dir + "/t.nhdr", {}); }, ErrorCode::CorruptData, {"t.gz"});
    // A stream cut before its first plane ends.
    const std::string good = deflate_bytes(samples(0, Z), true);
    write_text(dir + "/c.gz", good.substr(0, 12));
    write_text(dir + "/c.nhdr", kHead + "encoding: gzip\nendian: little\ndata file: c.gz\n");
    expect_error([&] { open_nrrd_planes(dir + "/c.nhdr", {}); }, ErrorCode::Truncated, {"c.gz"});
    // A valid stream that ends before a plane of a large claim (1 MiB planes).
    std::string half(512 << 10, '\0');
    for (char& c : half) c = char(rng());
    write_text(dir + "/p.gz", deflate_bytes(half, true));
    write_text(dir + "/p.nhdr",
               "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1024 1024 4\nencoding: gzip\ndata file: p.gz\n");
    expect_error([&] { open_nrrd_planes(dir + "/p.nhdr", {}); }, ErrorCode::Truncated,
                 {"p.gz", "truncated"});
    // A byte skip over garbage is inflated at open too.
    write_text(dir + "/s.nhdr", kHead + "encoding: gzip\nendian: little\nbyte skip: 3\ndata file: t.gz\n");
    expect_error([&] { open_nrrd_planes(dir + "/s.nhdr", {}); }, ErrorCode::CorruptData, {"t.gz"});
}
