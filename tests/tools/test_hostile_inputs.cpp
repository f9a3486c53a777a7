// Hostile inputs of issue 9, each crafted here and run through the command line
// as an attacker would: every one must end in exit code 4 (bad data) with a
// message naming the problem, and the refusal must stay under 100 MB of peak
// resident memory (measured from the child's rusage): claims are checked
// against the bytes actually present before anything is allocated for them.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "cli_runner.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

using namespace tetlod;
using namespace tetlod::tlod;
namespace fs = std::filesystem;

namespace {

// AddressSanitizer's shadow memory and quarantine add to every allocation's
// resident size: the release build is held to 100 MiB, a sanitized one to more.
#if defined(__SANITIZE_ADDRESS__)
#define TETLOD_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TETLOD_TEST_ASAN 1
#endif
#endif
#ifdef TETLOD_TEST_ASAN
constexpr long kMaxRefusalKb = 160 * 1024;
#else
constexpr long kMaxRefusalKb = 100 * 1024;
#endif

struct Measured {
    int code = -1;
    std::string err;
    long max_rss_kb = 0;
};

/// Runs `tetlod ARGS` in a child (exec replaces the shell) and reads its peak
/// resident set size from wait4.
Measured run_measured(const std::string& args, const std::string& tag) {
    const std::string out = tetlod_cli_test::tmp(tag + ".out"), err = tetlod_cli_test::tmp(tag + ".err");
    const std::string cmd = std::string("exec '") + TETLOD_CLI_PATH + "' " + args + " >'" + out + "' 2>'" + err + "'";
    const pid_t pid = fork();
    if (pid == 0) {
        execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
        _exit(127);
    }
    int status = 0;
    struct rusage ru {};
    wait4(pid, &status, 0, &ru);
    Measured m;
    m.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    m.err = tetlod_cli_test::slurp(err);
    m.max_rss_kb = ru.ru_maxrss;
    return m;
}

std::string fresh_dir(const std::string& name) {
    const fs::path d = fs::path(TETLOD_TEST_TMP) / ("hostile_" + name);
    fs::remove_all(d);
    fs::create_directories(d);
    return d.string();
}

void write_file(const std::string& path, const void* data, std::size_t n) {
    std::ofstream f(path, std::ios::binary);
    f.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
}
void write_text(const std::string& path, const std::string& s) { write_file(path, s.data(), s.size()); }

/// Expects a refusal: exit 4, every word of `needles` in stderr, bounded memory,
/// and no output file left behind.
void expect_refused(const std::string& args, const std::string& tag, const std::vector<std::string>& needles,
                    const std::string& output = "", int exit_code = 4) {
    SCOPED_TRACE(tag + ": tetlod " + args);
    const Measured m = run_measured(args, tag);
    EXPECT_EQ(m.code, exit_code) << m.err;
    for (const auto& n : needles) {
        EXPECT_NE(m.err.find(n), std::string::npos) << "missing '" << n << "' in: " << m.err;
    }
    EXPECT_LE(m.max_rss_kb, kMaxRefusalKb) << "peak RSS of the refusal: " << m.max_rss_kb << " KiB";
    if (!output.empty()) {
        EXPECT_FALSE(fs::exists(output)) << output;
    }
    std::printf("[ hostile ] %-34s exit %d, peak RSS %ld KiB\n", tag.c_str(), m.code, m.max_rss_kb);
}

// ---- .tlod containers ----

/// A zstd frame header claiming `content` bytes followed by one RLE last block
/// of `block` bytes: structurally a frame, but it cannot expand to its claim.
std::vector<std::byte> lying_zstd_frame(uint64_t content, uint32_t block = 16) {
    std::vector<std::byte> f;
    put_u32(f, 0xFD2FB528u);
    put_u8(f, 0xE0);  // 8-byte content size, single segment, no checksum, no dictionary
    put_u64(f, content);
    const uint32_t bh = 1u | (1u << 1) | (block << 3);  // last block, RLE
    put_le(f, bh, 3);
    put_u8(f, 0);
    return f;
}

/// The 48-byte MT header (docs/mt.md §5).
std::vector<std::byte> mt_header(Dims d, ValueType t, uint16_t flags, uint32_t nbase, uint32_t nupd, uint64_t raw,
                                 uint64_t stored) {
    std::vector<std::byte> h;
    for (char c : {'T', 'L', 'M', 'T'}) put_u8(h, uint8_t(c));  // (put_bytes trips a GCC 12 false warning)
    put_u16(h, 1);
    put_u16(h, flags);
    put_u32(h, uint32_t(d.x)), put_u32(h, uint32_t(d.y)), put_u32(h, uint32_t(d.z));
    put_u8(h, uint8_t(t));
    put_u8(h, 7);
    put_u16(h, 0);
    put_u32(h, nbase);
    put_u32(h, nupd);
    put_u64(h, raw);
    put_u64(h, stored);
    return h;
}

/// An MT-only container (spec §10) whose sections carry `header` and `payload`.
std::vector<std::byte> mt_only_container(Dims d, ValueType t, const std::vector<std::byte>& header,
                                         const std::vector<std::byte>& payload) {
    Metadata m;
    m.dims = d;
    m.type = t;
    ContainerWriter w;
    w.set_features(kFeatureMt);
    w.add(kSectionMetadata, kSectionCritical, 0, 0, serialize_metadata(m), 1);
    w.add_stored(kSectionMtHeader, kSectionCritical, 0, 0, header, header.size());
    w.add_stored(kSectionMtStructure, kSectionCritical, 0, 0, payload, payload.size());
    return w.finish();
}

std::string save(const std::string& dir, const std::string& name, const std::vector<std::byte>& bytes) {
    const std::string p = dir + "/" + name;
    write_file(p, bytes.data(), bytes.size());
    return p;
}

TEST(HostileInputs, MtPayloadClaimsRefusedBeforeAllocating) {
    const std::string dir = fresh_dir("mt");
    const Dims big{1280, 1280, 1280};  // 2.1 G points, under the MT's 2^31 limit
    const uint64_t n = uint64_t(big.count());
    struct Case {
        std::string name;
        std::vector<std::byte> file;
        std::vector<std::string> needles;
    };
    std::vector<Case> cases;
    {  // the 307-byte file: an f64 field-included MT claiming an 8 GiB payload
        const auto z = lying_zstd_frame(uint64_t{8} << 30);
        const auto h = mt_header(big, ValueType::F64, 1, uint32_t(n / 5), uint32_t(n - 1), uint64_t{8} << 30, z.size());
        cases.push_back({"mt_payload_8gib", mt_only_container(big, ValueType::F64, h, z), {"MT", "payload"}});
    }
    {  // a 4 GiB payload claim that the header's counts allow (419 M points, one base tet)
        const Dims d{1024, 1024, 400};
        const uint64_t m = uint64_t(d.count());
        const auto z = lying_zstd_frame(uint64_t{4} << 30);
        const auto h = mt_header(d, ValueType::U8, 1, 1, uint32_t(m - 1), uint64_t{4} << 30, z.size());
        cases.push_back({"mt_payload_4gib", mt_only_container(d, ValueType::U8, h, z), {"cannot expand"}});
    }
    {  // a base mesh of 2 GiB (2^27 tets) in a payload of a few bytes
        const auto z = lying_zstd_frame(4096);
        const auto h = mt_header(big, ValueType::U8, 1, uint32_t{1} << 27, uint32_t(n - 1), 4096, z.size());
        cases.push_back({"mt_base_2gib", mt_only_container(big, ValueType::U8, h, z), {"cannot hold"}});
    }
    {  // 2 G grid points with one base tet and no updates
        const auto z = lying_zstd_frame(4096);
        const auto h = mt_header(big, ValueType::U8, 1, 1, 0, 4096, z.size());
        cases.push_back({"mt_points_without_updates", mt_only_container(big, ValueType::U8, h, z), {"grid points"}});
    }
    for (const Case& c : cases) {
        const std::string in = save(dir, c.name + ".tlod", c.file);
        std::printf("[ hostile ] %s: %zu bytes\n", c.name.c_str(), c.file.size());
        const std::string out = dir + "/" + c.name + ".vtu";
        auto needles = c.needles;
        needles.push_back(in);
        expect_refused("extract '" + in + "' '" + out + "' --model mt --error 0", c.name, needles, out);
    }
}

/// An HT container claiming an n^3 u8 cube (n = 2^k + 1) whose chunk sections
/// are `bytes` long each: v2 range-coded (coding 2) or v1 zstd (coding 1, every
/// section a frame claiming the chunk's raw size).
std::vector<std::byte> ht_claim(int k, std::size_t bytes, bool v1) {
    const int64_t n = (int64_t{1} << k) + 1;
    Metadata m;
    m.dims = {n, n, n};
    ContainerWriter w;
    w.set_features(kFeatureHt);
    w.add(kSectionMetadata, kSectionCritical, 0, 0, serialize_metadata(m), 1);
    std::vector<std::byte> hh;
    for (uint8_t v : {uint8_t(k), uint8_t(0), uint8_t(16), uint8_t(4), uint8_t(v1 ? 1 : 2), uint8_t(v1 ? 1 : 2)})
        put_u8(hh, v);
    put_u16(hh, 0);
    for (int a = 0; a < 3; ++a) put_u32(hh, uint32_t(n - 1));
    put_u32(hh, 0);
    w.add_stored(kSectionHtHeader, kSectionCritical, 0, 0, hh, hh.size());
    for (int t = k; t >= 0; --t) {
        // Points of cycle t in the whole cube (one brick per cycle).
        const int64_t h = int64_t{1} << t, c = (n - 1) / h + 1, c2 = (n - 1) / (2 * h) + 1;
        const uint64_t pts = uint64_t(t == k ? c * c * c : c * c * c - c2 * c2 * c2);
        const uint64_t diamonds = t == k ? 0 : pts;
        if (v1) {
            auto f = lying_zstd_frame(pts);
            w.add_stored(kSectionHtField, kSectionCritical | kSectionZstd, uint32_t(t), 0, f, pts);
            auto e = lying_zstd_frame(2 * diamonds);
            w.add_stored(kSectionHtErrors, kSectionCritical | kSectionZstd, uint32_t(t), 0, e, 2 * diamonds);
        } else {
            std::vector<std::byte> s(bytes, std::byte{0});
            w.add_stored(kSectionHtField, kSectionCritical, uint32_t(t), 0, s, s.size());
            std::vector<std::byte> e(t == k ? 0 : bytes, std::byte{0});
            w.add_stored(kSectionHtErrors, kSectionCritical, uint32_t(t), 0, e, e.size());
        }
    }
    return w.finish();
}

TEST(HostileInputs, HtClaimOf1025CubedRefusedBeforeAllocating) {
    const std::string dir = fresh_dir("ht");
    {  // format 2: 939 M values of the finest cycle cannot fit in 64 coded bytes
        const std::string in = save(dir, "ht_v2_1025.tlod", ht_claim(10, 64, false));
        const std::string out = dir + "/v2.raw";
        expect_refused("decode '" + in + "' '" + out + "'", "ht_v2_1025", {in, "cannot fit"}, out);
        expect_refused("extract '" + in + "' '" + dir + "/v2.vtu' --error 0", "ht_v2_1025_extract", {"cannot fit"});
    }
    {  // format 1: zstd frames of 20 bytes claiming the chunks' raw sizes
        const std::string in = save(dir, "ht_v1_1025.tlod", ht_claim(10, 0, true));
        const std::string out = dir + "/v1.raw";
        expect_refused("decode '" + in + "' '" + out + "'", "ht_v1_1025", {in, "impossible"}, out);
    }
}

// ---- NRRD and MetaImage ----

std::vector<unsigned char> random_bytes(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<unsigned char> b(n);
    for (auto& c : b) c = static_cast<unsigned char>(rng());
    return b;
}

/// A valid gzip stream of `raw`.
std::vector<unsigned char> gzip(const std::vector<unsigned char>& raw) {
    z_stream zs{};
    deflateInit2(&zs, 1, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
    std::vector<unsigned char> out(deflateBound(&zs, raw.size()) + 64);
    zs.next_in = const_cast<unsigned char*>(raw.data());
    zs.avail_in = static_cast<uInt>(raw.size());
    zs.next_out = out.data();
    zs.avail_out = static_cast<uInt>(out.size());
    deflate(&zs, Z_FINISH);
    out.resize(zs.total_out);
    deflateEnd(&zs);
    return out;
}

TEST(HostileInputs, CompressedVolumeClaimsRefusedBeforeAllocating) {
    const std::string dir = fresh_dir("gzip");
    // 1 GiB claimed, ~1.1 MB of bytes present: enough for the deflate bound.
    const std::string nrrd_head =
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1024 1024 1024\nencoding: gzip\n\n";
    {  // gzip magic then garbage
        auto junk = random_bytes(1100000, 1);
        junk[0] = 0x1f, junk[1] = 0x8b, junk[2] = 8, junk[3] = 0;
        std::string f = nrrd_head + std::string(junk.begin(), junk.end());
        const std::string in = dir + "/garbage.nrrd";
        write_text(in, f);
        expect_refused("convert '" + in + "' '" + dir + "/g.tlod'", "nrrd_gzip_garbage", {in, "corrupt"},
                       dir + "/g.tlod");
    }
    {  // a valid stream, far too short for its claim
        const auto z = gzip(random_bytes(1200000, 2));
        const std::string in = dir + "/short.nrrd";
        write_text(in, nrrd_head + std::string(z.begin(), z.end()));
        expect_refused("convert '" + in + "' '" + dir + "/s.tlod'", "nrrd_gzip_short", {in, "truncated"},
                       dir + "/s.tlod");
    }
    {  // MetaImage, zlib garbage in a detached data file
        auto junk = random_bytes(1100000, 3);
        junk[0] = 0x78, junk[1] = 0x9c;
        write_file(dir + "/junk.zraw", junk.data(), junk.size());
        const std::string in = dir + "/garbage.mhd";
        write_text(in, "ObjectType = Image\nNDims = 3\nDimSize = 1024 1024 1024\nElementType = MET_UCHAR\n"
                       "CompressedData = True\nElementDataFile = junk.zraw\n");
        expect_refused("convert '" + in + "' '" + dir + "/m.tlod'", "mhd_zlib_garbage", {"junk.zraw", "corrupt"},
                       dir + "/m.tlod");
    }
    {  // raw data file far smaller than the claim
        write_file(dir + "/small.raw", "abcd", 4);
        const std::string in = dir + "/raw.nhdr";
        write_text(in, "NRRD0004\ntype: float\ndimension: 3\nsizes: 1024 1024 1024\nencoding: raw\n"
                       "data file: small.raw\n");
        expect_refused("convert '" + in + "' '" + dir + "/r.tlod'", "nhdr_raw_short", {"small.raw", "truncated"},
                       dir + "/r.tlod");
    }
}

TEST(HostileInputs, DataFilePatternOverflowRefused) {
    const std::string dir = fresh_dir("pattern");
    for (const std::string range : {"0 -9223372036854775808 -1", "-9223372036854775808 9223372036854775807 1",
                                    "9223372036854775807 -9223372036854775808 -3"}) {
        SCOPED_TRACE(range);
        const std::string nhdr = dir + "/p.nhdr";
        write_text(nhdr, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: s%d " + range +
                             "\n");
        expect_refused("convert '" + nhdr + "' '" + dir + "/p.tlod'", "nrrd_pattern", {nhdr, "\"data file\""});
        const std::string mhd = dir + "/p.mhd";
        write_text(mhd, "NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\nElementDataFile = s%d " + range + "\n");
        expect_refused("convert '" + mhd + "' '" + dir + "/q.tlod'", "mhd_pattern", {mhd, "ElementDataFile"});
    }
    // A million files named by a pattern: the first missing one stops the read
    // (missing file: exit 3) before the others are listed.
    {
        const std::string big = dir + "/big.nhdr";
        write_text(big, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1024 1024 1024\nencoding: raw\n"
                        "data file: a_rather_long_slice_name_%d.raw 1 1048576 1\n");
        expect_refused("convert '" + big + "' '" + dir + "/big.tlod'", "nrrd_pattern_1m",
                       {big, "a_rather_long_slice_name_1.raw"}, dir + "/big.tlod", 3);
    }
    // An empty range (wrong step sign) is refused as such.
    const std::string nhdr = dir + "/e.nhdr";
    write_text(nhdr, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: s%d 1 5 -1\n");
    expect_refused("convert '" + nhdr + "' '" + dir + "/e.tlod'", "nrrd_pattern_empty", {"empty or endless"});
}

TEST(HostileInputs, DataFilesOutsideTheHeaderFolderNeedTheFlag) {
    const std::string dir = fresh_dir("external");
    fs::create_directories(dir + "/hdr");
    fs::create_directories(dir + "/elsewhere");
    std::vector<unsigned char> data(64);
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<unsigned char>(i);
    write_file(dir + "/elsewhere/secret.raw", data.data(), data.size());
    write_file(dir + "/hdr/inside.raw", data.data(), data.size());
    const std::string abs_secret = fs::absolute(dir + "/elsewhere/secret.raw").string();
    struct Case {
        std::string tag, header, name;
    };
    // A link inside the folder that points outside it, and a folder reached
    // through a link (fine: both sides are resolved).
    fs::create_symlink(fs::absolute(dir + "/elsewhere/secret.raw"), dir + "/hdr/link.raw");
    fs::create_directory_symlink(fs::absolute(dir + "/hdr"), dir + "/hdr_link");
    const std::vector<Case> cases = {
        {"nrrd_symlink", "hdr/e.nhdr", "link.raw"},
        {"mhd_symlink", "hdr/f.mhd", "link.raw"},
        {"nrrd_dotdot", "hdr/a.nhdr", "../elsewhere/secret.raw"},
        {"nrrd_absolute", "hdr/b.nhdr", abs_secret},
        {"mhd_dotdot", "hdr/c.mhd", "../elsewhere/secret.raw"},
        {"mhd_absolute", "hdr/d.mhd", abs_secret},
    };
    for (const Case& c : cases) {
        const std::string hp = dir + "/" + c.header;
        if (c.header.ends_with(".nhdr"))
            write_text(hp, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: " + c.name +
                               "\n");
        else
            write_text(hp, "NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\nElementDataFile = " + c.name + "\n");
        const std::string out = dir + "/" + c.tag + ".tlod";
        expect_refused("convert '" + hp + "' '" + out + "'", c.tag, {hp, c.name, "--allow-external-data"}, out);
        const auto ok = tetlod_cli_test::run("convert '" + hp + "' '" + out + "' --allow-external-data");
        EXPECT_EQ(ok.code, 0) << ok.err;
        EXPECT_TRUE(fs::exists(out));
    }
    // Through a linked folder, a data file really inside it is read without the flag.
    {
        write_text(dir + "/hdr/in.nhdr",
                   "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: inside.raw\n");
        const auto linked = tetlod_cli_test::run("convert '" + dir + "/hdr_link/in.nhdr' '" + dir + "/linked.tlod'");
        EXPECT_EQ(linked.code, 0) << linked.err;
    }
    // A header given by a bare relative name (no folder part) reads its data file beside it.
    {
        write_text(dir + "/hdr/rel.nhdr",
                   "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: inside.raw\n");
        const auto rel = tetlod_cli_test::sh("cd '" + dir + "/hdr' && '" + TETLOD_CLI_PATH +
                                             "' convert rel.nhdr rel.tlod");
        EXPECT_EQ(rel.code, 0) << rel.err;
    }
    // A name inside the folder (even spelled with "..") needs no flag.
    const std::string hp = dir + "/hdr/e.nhdr";
    write_text(hp, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: ../hdr/inside.raw\n");
    const auto ok = tetlod_cli_test::run("convert '" + hp + "' '" + dir + "/inside.tlod'");
    EXPECT_EQ(ok.code, 0) << ok.err;
}

TEST(HostileInputs, NonFiniteGeometryRefusedWhereTheVolumeIsRead) {
    const std::string dir = fresh_dir("nonfinite");
    std::vector<unsigned char> data(64, 7);
    write_file(dir + "/v.raw", data.data(), data.size());
    const std::string head = "NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n";
    {
        const std::string in = dir + "/offset.mhd";
        write_text(in, head + "Offset = nan inf -inf\nElementDataFile = v.raw\n");
        expect_refused("convert '" + in + "' '" + dir + "/o.tlod'", "mhd_offset_nan", {in, "Offset", "not finite"},
                       dir + "/o.tlod");
    }
    {
        const std::string in = dir + "/spacing.mhd";
        write_text(in, head + "ElementSpacing = 1 inf 1\nElementDataFile = v.raw\n");
        expect_refused("convert '" + in + "' '" + dir + "/s.tlod'", "mhd_spacing_inf", {in, "ElementSpacing"},
                       dir + "/s.tlod");
    }
    {  // the same volume with a finite offset converts, and its container reads back
        const std::string in = dir + "/fine.mhd";
        write_text(in, head + "Offset = 1.5 -2 3\nElementDataFile = v.raw\n");
        const auto c = tetlod_cli_test::run("convert '" + in + "' '" + dir + "/f.tlod'");
        ASSERT_EQ(c.code, 0) << c.err;
        const auto v = tetlod_cli_test::run("verify '" + dir + "/f.tlod' --deep");
        EXPECT_EQ(v.code, 0) << v.err;
    }
}

TEST(HostileInputs, ContainerWriterRefusesWhatItsReaderRefuses) {
    Metadata m;
    m.dims = {4, 4, 4};
    for (int bad = 0; bad < 4; ++bad) {
        Metadata b = m;
        if (bad == 0) b.origin[0] = std::nan("");
        if (bad == 1) b.origin[2] = -INFINITY;
        if (bad == 2) b.spacing[1] = INFINITY;
        if (bad == 3) b.value_range = {5, 1};
        try {
            (void)serialize_metadata(b);
            ADD_FAILURE() << "case " << bad << " was serialized";
        } catch (const Error& e) {
            EXPECT_EQ(e.code(), ErrorCode::CorruptData) << e.what();
            EXPECT_NE(std::string(e.what()).find("METADATA"), std::string::npos) << e.what();
        }
    }
    EXPECT_TRUE(parse_metadata(serialize_metadata(m)).ok());
}

// A 10 KiB .vdb found by fuzz_vdb_reader (kept in its seed corpus) made
// OpenVDB allocate 7 GB in the isolated child until the time limit killed it.
// The child's memory limit (IsolationOptions, by input size) now ends it at
// the first oversized allocation.
TEST(HostileInputs, CorruptVdbCannotMakeTheLibraryAllocateGigabytes) {
#ifdef TETLOD_SANITIZED
    GTEST_SKIP() << "under AddressSanitizer the child has no memory limit (its shadow memory would exceed any)";
#endif
    const std::string in = std::string(TETLOD_FUZZ_CORPUS_DIR) + "/vdb/regress_openvdb_7gb_allocation.vdb";
    ASSERT_TRUE(fs::exists(in)) << in;
    const std::string dir = fresh_dir("vdb_alloc");
    const std::string out = dir + "/v.tlod";
    expect_refused("convert '" + in + "' '" + out + "'", "vdb_fuzz_7gb_allocation", {in}, out);
}

}  // namespace
