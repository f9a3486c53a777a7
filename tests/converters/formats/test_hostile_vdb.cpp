// Hostile OpenVDB inputs: single flipped bits (OpenVDB overflows its heap on
// some), metadata claiming huge dims, dims as text, a FIFO named .vdb, TBB
// already running in the reading process. Every read ends in success or a clean
// tetlod::Error, quickly, within bounded memory.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "cli_rusage.hpp"
#include "format_test_util.hpp"
#include "tetlod/converters/vdb.hpp"

namespace tetlod {
namespace {

using test::slurp;
using test::spit;
using test::tmp_dir;

// A small FloatGrid file written by tetlod (dims_xyz 6 5 4 as vec3i metadata).
std::string small_vdb(const std::string& dir) {
    const std::string path = dir + "/small.vdb";
    Volume v = test::make_volume(ValueType::F32, {6, 5, 4});
    v.metadata["dims_xyq"] = "placeholder";  // same length as dims_xyz, patched by tests
    write_vdb(v, path);
    return path;
}

// The bytes of metadata entry `name` (u32 length + name + u32 length + type + u32 size + value).
std::size_t find_meta(const std::string& bytes, const std::string& name) {
    std::string key(4, '\0');
    const uint32_t n = static_cast<uint32_t>(name.size());
    std::memcpy(key.data(), &n, 4);
    key += name;
    const std::size_t at = bytes.find(key);
    EXPECT_NE(at, std::string::npos) << name;
    return at;
}

Error read_error(const std::string& path) {
    VolumeReadOptions opt;
    opt.isolation.timeout_seconds = 20;
    try {
        read_vdb(path, opt);
    } catch (const Error& e) {
        return e;
    }
    ADD_FAILURE() << "read succeeded";
    return Error(ErrorCode::Ok, "");
}

TEST(HostileVdb, FlippedBitsNeverCrashOrHang) {
    const std::string dir = tmp_dir("vdb_flips");
    const std::string bytes = slurp(small_vdb(dir));
    const std::string path = dir + "/flipped.vdb";
    VolumeReadOptions opt;
    opt.isolation.timeout_seconds = 3;
    int ok = 0, errors = 0, crashes = 0, hangs = 0;
    // Every byte of the header and descriptors, then a deterministic sample of
    // about 300 more positions (each read forks a process: keep it bounded).
    const std::size_t stride = std::max<std::size_t>(1, bytes.size() / 300);
    for (std::size_t pos = 0; pos < bytes.size(); pos += pos < 256 ? 1 : stride) {
        std::string m = bytes;
        m[pos] = static_cast<char>(m[pos] ^ (1 << (pos * 3 % 8)));
        spit(path, m);
        try {
            read_vdb(path, opt);
            ++ok;
        } catch (const Error& e) {
            const std::string w = e.what();
            ++errors;
            if (w.find("crashed") != std::string::npos) ++crashes;
            if (w.find("did not finish") != std::string::npos) ++hangs;
        }
    }
    std::printf("bits flipped in a %zu-byte file: %d read, %d refused (%d library crashes, %d hangs caught)\n", bytes.size(), ok,
                errors, crashes, hangs);
    EXPECT_GT(errors, 0);
}

// dims_xyz 2000^3 float (32 GB dense) in a file of a few KiB: refused before
// OpenVDB reads the grid, in bounded memory, exit 4.
TEST(HostileVdb, HugeDimsMetadataIsRefusedInBoundedMemory) {
    const std::string dir = tmp_dir("vdb_huge");
    std::string bytes = slurp(small_vdb(dir));
    const std::size_t at = find_meta(bytes, "dims_xyz") + 4 + 8 + 4 + 5 + 4;
    ASSERT_EQ(bytes.substr(at - 9, 5), "vec3i");
    const int32_t huge[3] = {2000, 2000, 2000};
    std::memcpy(bytes.data() + at, huge, 12);
    const std::string path = dir + "/huge.vdb";
    spit(path, bytes);
    const Error e = read_error(path);
    EXPECT_EQ(e.code(), ErrorCode::TooLarge) << e.what();
    EXPECT_NE(std::string(e.what()).find("refused before allocating"), std::string::npos) << e.what();
    const auto r = test::run_cli({"convert", path, dir + "/out.tlod"}, dir + "/err.txt");
    EXPECT_EQ(r.code, 4) << r.err;
    EXPECT_LE(r.max_rss_kib, 100 * 1024) << "peak RSS of the refusal";
}

// dims_xyz as a string: three integers are fine, anything else is bad data
// (exit 4 with a message), never an internal error.
TEST(HostileVdb, TextDimsAreBadDataNotAnInternalError) {
    const std::string dir = tmp_dir("vdb_text_dims");
    const std::string base = slurp(small_vdb(dir));
    auto with_text_dims = [&](const std::string& value) {
        // Rename tetlod's own vec3i entry away and the placeholder string to dims_xyz.
        std::string b = base;
        b[find_meta(b, "dims_xyz") + 4 + 7] = 'w';
        const std::size_t p = find_meta(b, "dims_xyq");
        b[p + 4 + 7] = 'z';
        // value: after name, u32 + "string", u32 size, bytes ("placeholder", 11 bytes)
        const std::size_t size_at = p + 4 + 8 + 4 + 6;
        uint32_t n = static_cast<uint32_t>(value.size());
        std::string out = b.substr(0, size_at) + std::string(reinterpret_cast<char*>(&n), 4) + value +
                          b.substr(size_at + 4 + 11);
        // Every grid offset after the value moves by the size difference.
        const int64_t delta = static_cast<int64_t>(value.size()) - 11;
        const std::size_t offsets = out.find("Tree_float_5_4_3") + 16 + 4;  // after the empty instance parent
        for (int i = 0; i < 3; ++i) {
            int64_t o;
            std::memcpy(&o, out.data() + offsets + 8 * i, 8);
            if (i > 0) o += delta;
            std::memcpy(out.data() + offsets + 8 * i, &o, 8);
        }
        const std::string path = dir + "/text_" + std::to_string(value.size()) + ".vdb";
        spit(path, out);
        return path;
    };
    {
        VolumeReadOptions opt;
        const Volume v = read_vdb(with_text_dims("6 5 4"), opt);
        EXPECT_EQ(v.dims, (Dims{6, 5, 4}));
    }
    for (const std::string bad : {"abc", "99999999999999999999 1 1", "6 5", "6.5 5 4", "-6 5 4"}) {
        SCOPED_TRACE(bad);
        const std::string path = with_text_dims(bad);
        const Error e = read_error(path);
        EXPECT_EQ(e.code(), ErrorCode::CorruptData) << e.what();
        EXPECT_NE(std::string(e.what()).find("dims_xyz"), std::string::npos) << e.what();
        const auto r = test::run_cli({"convert", path, dir + "/out.tlod"}, dir + "/err.txt");
        EXPECT_EQ(r.code, 4) << r.err;
        EXPECT_NE(r.err.find("is not three positive integers"), std::string::npos) << r.err;
    }
}

TEST(HostileVdb, FifoAndNonVdbAreRefusedBeforeTheLibrary) {
    const std::string dir = tmp_dir("vdb_fifo");
    ASSERT_EQ(::mkfifo((dir + "/pipe.vdb").c_str(), 0600), 0);
    const Error e = read_error(dir + "/pipe.vdb");
    EXPECT_EQ(e.code(), ErrorCode::IoError);
    EXPECT_NE(std::string(e.what()).find("FIFO"), std::string::npos) << e.what();
    EXPECT_THROW(list_vdb_grids(dir + "/pipe.vdb"), Error);
    spit(dir + "/text.vdb", "not a vdb file, just some text");
    EXPECT_EQ(read_error(dir + "/text.vdb").code(), ErrorCode::BadMagic);
    std::string v = slurp(small_vdb(dir));
    v[8] = static_cast<char>(250);  // format version 250
    spit(dir + "/future.vdb", v);
    EXPECT_EQ(read_error(dir + "/future.vdb").code(), ErrorCode::UnsupportedVersion);
}

// A claimed string length of 2 GiB would make OpenVDB allocate and fill it.
TEST(HostileVdb, HugeStringClaimIsRefusedBeforeTheLibrary) {
    const std::string dir = tmp_dir("vdb_string");
    std::string bytes = slurp(small_vdb(dir));
    const std::size_t at = find_meta(bytes, "dims_xyq");
    const uint32_t huge = 0x7fffff00u;
    std::memcpy(bytes.data() + at, &huge, 4);
    spit(dir + "/s.vdb", bytes);
    const Error e = read_error(dir + "/s.vdb");
    EXPECT_EQ(e.code(), ErrorCode::CorruptData) << e.what();
    EXPECT_EQ(std::string(e.what()).find("OpenVDB"), std::string::npos) << "refused by the guard: " << e.what();
}

TEST(HostileVdb, ReadsWhileTbbWorkersRunInTheParent) {
    std::atomic<long> sum{0};
    tbb::parallel_for(0, 100000, [&](int i) { sum += i; });
    ASSERT_GT(sum.load(), 0);
    const std::string dir = tmp_dir("vdb_tbb");
    const Volume orig = test::make_volume(ValueType::F32, {6, 5, 4});
    const std::string path = small_vdb(dir);
    const Volume v = read_vdb(path);
    EXPECT_EQ(v.dims, orig.dims);
    EXPECT_EQ(list_vdb_grids(path).size(), 1u);
    VolumeReadOptions opt;
    opt.isolation.enabled = false;
    const Volume w = read_vdb(path, opt);
    EXPECT_EQ(v.data, w.data);
    EXPECT_EQ(v.metadata, w.metadata);
}

}  // namespace
}  // namespace tetlod
