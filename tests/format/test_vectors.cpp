// Test vectors beside the spec (spec/test-vectors/): small .tlod files, their
// decoded contents as raw files, and their expected metadata as JSON. Set
// TETLOD_REGENERATE_VECTORS=1 to rewrite them (after a deliberate format change,
// together with a version bump in the spec).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>
#include <zstd.h>
#define XXH_INLINE_ALL
#include <xxhash.h>
#include <cmath>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/lossy_field.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/format/container.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;

namespace {

struct Vector {
    const char* name;
    Dims dims;
    ValueType type;
    bool pad;
    /// Vectors of an older format version are kept, never regenerated: readers
    /// must go on decoding them. (2.1 changed nothing for HT-only files: the 2.0
    /// vectors stand; the 2.1 MT vectors are in test_mt_container.cpp.) Since
    /// 3.6 only the newest version's vectors are regenerated (3.8 now): a later
    /// writer may code a chunk its own way (those with the writer's choice could
    /// take range-2d), and a vector stands for its version.
    bool current;
    /// Format 3.0 (chunk modes, spec §6.4): the volume's shape and the forced
    /// mode (-1: the encoder's choice), so that every mode occurs in a vector.
    enum Shape { Noisy, Sparse, Linear, Constant } shape = Noisy;
    int mode = -1;
    /// Format 3.2: the vector's section table is the compact one (spec §4.4);
    /// the 3.0 vectors keep the full table, as they were written.
    bool compact = false;
    /// Format 3.3: the field quantized to the lattice of this E (spec §5.1),
    /// written LOSSY with field.max_error = E (0: lossless).
    double max_error = 0;
};

// Named by model and format version.
const Vector kVectors[] = {
    {"ht_v1_u8_9x6x5", {9, 6, 5}, ValueType::U8, false, false},
    {"ht_v1_i16_17x17x17", {17, 17, 17}, ValueType::I16, false, false},
    {"ht_v1_f32_6x5x4_padded", {6, 5, 4}, ValueType::F32, true, false},
    {"ht_v2_u8_9x6x5", {9, 6, 5}, ValueType::U8, false, false},
    {"ht_v2_i16_17x17x17", {17, 17, 17}, ValueType::I16, false, false},
    {"ht_v2_f32_6x5x4_padded", {6, 5, 4}, ValueType::F32, true, false},
    {"ht_v2_u16_33x20x9", {33, 20, 9}, ValueType::U16, false, false},
    {"ht_v3_u8_9x6x5", {9, 6, 5}, ValueType::U8, false, false},
    {"ht_v3_f32_6x5x4_padded", {6, 5, 4}, ValueType::F32, true, false},
    {"ht_v3_i16_17x17x17_samples", {17, 17, 17}, ValueType::I16, false, false, Vector::Noisy, 2},
    {"ht_v3_u8_33x20x9_sparse", {33, 20, 9}, ValueType::U8, false, false, Vector::Sparse},
    {"ht_v3_u16_17x9x9_linear", {17, 9, 9}, ValueType::U16, false, false, Vector::Linear, 3},
    {"ht_v3_u8_9x9x5_constant", {9, 9, 5}, ValueType::U8, false, false, Vector::Constant, 1},
    {"ht_v3.2_u8_33x20x9_sparse_compact", {33, 20, 9}, ValueType::U8, false, false, Vector::Sparse, -1, true},
    {"ht_v3.2_i16_17x17x17_compact", {17, 17, 17}, ValueType::I16, false, false, Vector::Noisy, -1, true},
    {"ht_v3.3_f32_17x13x9_lattice", {17, 13, 9}, ValueType::F32, false, false, Vector::Noisy, 4, true, 0.75},
    {"ht_v3.3_i16_17x17x17_lattice", {17, 17, 17}, ValueType::I16, false, false, Vector::Noisy, 4, true, 2.0},
    // Format 3.6: range-2d (mode 5) forced on every field chunk with points.
    {"ht_v3.6_u8_33x20x9_range2d", {33, 20, 9}, ValueType::U8, false, false, Vector::Noisy, 5, true},
    {"ht_v3.6_f32_17x13x9_range2d", {17, 13, 9}, ValueType::F32, false, false, Vector::Noisy, 5, true},
    // Format 3.7: static (mode 6) forced on every field chunk with points.
    {"ht_v3.7_u8_33x20x9_static", {33, 20, 9}, ValueType::U8, false, false, Vector::Sparse, 6, true},
    {"ht_v3.7_f32_17x13x9_static", {17, 13, 9}, ValueType::F32, false, false, Vector::Noisy, 6, true},
    // Format 3.8: range-exp (mode 7) forced on every error chunk with diamonds.
    {"ht_v3.8_u8_33x20x9_rangeexp", {33, 20, 9}, ValueType::U8, false, true, Vector::Sparse, 7, true},
    {"ht_v3.8_f32_17x13x9_rangeexp", {17, 13, 9}, ValueType::F32, false, true, Vector::Noisy, 7, true},
};

/// Spec §6.4 (mode 4), read from the spec alone: the lattice step of a
/// stated E, and whether a sample is the value of its own index.
double spec_step(ValueType t, double e) {
    return (t == ValueType::F32 || t == ValueType::F64) ? 2 * e : 2 * std::floor(std::min(e, 1099511627776.0)) + 1;
}
bool spec_on_lattice(ValueType t, const char* p, double s) {
    if (t == ValueType::F32) {
        float x;
        std::memcpy(&x, p, 4);
        double q = std::nearbyint(double(x) / s);
        if (std::isnan(q)) q = 0;
        q = std::clamp(q, -4503599627370496.0, 4503599627370496.0);
        const float back = q == 0 ? 0.0f : float(q * s);
        return std::memcmp(&back, &x, 4) == 0;
    }
    if (t == ValueType::I16) {
        int16_t x;
        std::memcpy(&x, p, 2);
        return int64_t(x) % int64_t(s) == 0;
    }
    ADD_FAILURE() << "type not covered";
    return false;
}

/// The vector's volume: the noisy test volume, or a sparse blob on zeros, or
/// a linear ramp (its chunks mostly exact predictions: zero-residual), or a
/// constant.
Volume vector_volume(const Vector& v) {
    if (v.shape == Vector::Noisy) return tlodtest::make_volume(v.dims, v.type, 42);
    Volume vol = Volume::allocate(v.dims, v.type);
    dispatch_value_type(v.type, [&](auto tv) {
        using T = decltype(tv);
        for (int64_t z = 0; z < v.dims.z; ++z)
            for (int64_t y = 0; y < v.dims.y; ++y)
                for (int64_t x = 0; x < v.dims.x; ++x) {
                    const int64_t r2 = (x - 20) * (x - 20) + (y - 9) * (y - 9) + (z - 4) * (z - 4);
                    const int64_t val = v.shape == Vector::Sparse   ? (r2 < 16 ? 200 - 9 * r2 : 0)
                                        : v.shape == Vector::Linear ? 3 * x + 5 * y + 7 * z
                                                                    : 77;
                    vol.as<T>()[v.dims.index(x, y, z)] = T(val);
                }
    });
    return vol;
}

/// Sections per chunk mode (table Flags bits 8-11), HT_FIELD then HT_ERRORS.
nlohmann::json chunk_modes(const tlod::ContainerReader& r) {
    static const char* const names[] = {"range", "constant", "samples", "zero-residual", "lattice", "range-2d", "static", "range-exp"};
    nlohmann::json j = nlohmann::json::object();
    for (const auto& s : r.sections())
        if (s.type == tlod::kSectionHtField || s.type == tlod::kSectionHtErrors) {
            const uint32_t m = tlod::section_mode(s.flags);
            auto& slot = j[tlod::section_type_name(s.type)][m < 8 ? names[m] : "unknown"];
            slot = slot.is_null() ? 1 : slot.get<int>() + 1;
        }
    return j;
}

std::string dir() { return std::string(TETLOD_SPEC_DIR) + "/test-vectors/"; }

std::vector<char> slurp(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string expected_json(const Vector& v, const Volume& vol, const tlod::Metadata& m, const nlohmann::json& modes) {
    std::ostringstream o;
    o.precision(17);
    o << "{\n  \"file\": \"" << v.name << ".tlod\",\n  \"format_version\": \"" << (v.mode == 7 ? "3.8" : v.mode == 6 ? "3.7" : v.mode == 5 ? "3.6" : v.max_error > 0 ? "3.3" : v.compact ? "3.2" : "3.0") << "\",\n"
      << "  \"dims\": [" << m.dims.x << ", " << m.dims.y << ", " << m.dims.z << "],\n"
      << "  \"value_type\": \"" << value_type_name(m.type) << "\",\n"
      << "  \"spacing\": [" << m.spacing[0] << ", " << m.spacing[1] << ", " << m.spacing[2] << "],\n"
      << "  \"origin\": [" << m.origin[0] << ", " << m.origin[1] << ", " << m.origin[2] << "],\n"
      << "  \"value_range\": [" << m.value_range[0] << ", " << m.value_range[1] << "],\n"
      << "  \"padded\": " << (v.pad ? "true" : "false") << ",\n"
      << "  \"raw\": \"" << v.name << ".raw (little-endian, x fastest, " << vol.data.size()
      << " bytes)\",\n  \"errors\": \"" << v.name
      << ".errors.f32 (float32 little-endian per grid point of the HT box, decoded bounds)\",\n"
      << "  \"format_keys\": {";
    bool first = true;
    for (const auto& [k, val] : m.format_keys) {
        o << (first ? "\n" : ",\n") << "    \"" << k << "\": \"" << val << "\"";
        first = false;
    }
    o << "\n  },\n  \"user_keys\": {";
    first = true;
    for (const auto& [k, val] : m.user_keys) {
        o << (first ? "\n" : ",\n") << "    \"" << k << "\": \"" << val << "\"";
        first = false;
    }
    o << "\n  },\n  \"chunk_modes\": " << modes.dump() << "\n}\n";
    return o.str();
}

/// A table entry as the independent reading below sees it.
struct Entry {
    uint64_t type, flags, off, stored, raw, checksum;
    uint64_t arg0 = 0, arg1 = 0;
};

uint64_t le_at(const unsigned char* p, int n) {
    uint64_t x = 0;
    for (int i = 0; i < n; ++i) x |= uint64_t(p[i]) << (8 * i);
    return x;
}

/// Spec §4.2: Section_Count entries of 48 bytes at offset 64, checked against the table checksum.
std::vector<Entry> full_entries(const unsigned char* f, uint64_t n) {
    EXPECT_EQ(le_at(f + 48, 8), XXH64(f + 64, n * 48, 0));  // table checksum
    std::vector<Entry> out;
    for (uint64_t i = 0; i < n; ++i) {
        const unsigned char* e = f + 64 + 48 * i;
        out.push_back({le_at(e, 4), le_at(e + 4, 4), le_at(e + 8, 8), le_at(e + 16, 8), le_at(e + 24, 8),
                       le_at(e + 40, 8), le_at(e + 32, 4), le_at(e + 36, 4)});
    }
    return out;
}

/// Spec §4.4, read from the spec alone: a u32 frame size at offset 64, the
/// frame, its content seven columns of LEB128 varints / u64 checksums, the
/// offsets the running sum of the stored sizes after the table.
std::vector<Entry> compact_entries(const unsigned char* f, uint64_t file_size, uint64_t n) {
    const uint64_t frame_size = le_at(f + 64, 4);
    EXPECT_LE(68 + frame_size, file_size);
    EXPECT_EQ(le_at(f + 48, 8), XXH64(f + 64, 4 + frame_size, 0));  // table checksum: size field + frame
    const unsigned long long content_size = ZSTD_getFrameContentSize(f + 68, frame_size);
    EXPECT_LE(content_size, 48 * n);
    std::vector<unsigned char> c(content_size);
    EXPECT_EQ(ZSTD_decompress(c.data(), c.size(), f + 68, frame_size), content_size);
    std::size_t pos = 0;
    auto varint = [&] {
        uint64_t v = 0;
        for (int shift = 0; pos < c.size(); shift += 7) {
            const unsigned char b = c[pos++];
            v |= uint64_t(b & 0x7f) << shift;
            if (!(b & 0x80)) return v;
        }
        ADD_FAILURE() << "table content ends inside a varint";
        return v;
    };
    auto delta = [&](uint64_t prev) {  // zigzag of the wrapping u32 difference
        const uint32_t z = uint32_t(varint());
        const int64_t d = (z & 1) ? -int64_t(z >> 1) - 1 : int64_t(z >> 1);
        return uint64_t(uint32_t(int64_t(prev) + d));
    };
    std::vector<Entry> out(n);
    for (auto& e : out) e.type = varint();
    for (auto& e : out) e.flags = varint();
    uint64_t a0 = 0, a1 = 0;
    for (auto& e : out) e.arg0 = a0 = delta(a0);
    for (auto& e : out) e.arg1 = a1 = delta(a1);
    for (auto& e : out) e.stored = varint();
    for (auto& e : out) e.raw = (e.flags & 1) ? varint() : e.stored;
    for (auto& e : out) {
        e.checksum = XXH64(nullptr, 0, 0);
        if (e.stored > 0 && pos + 8 <= c.size()) {
            e.checksum = le_at(c.data() + pos, 8);
            pos += 8;
        }
    }
    EXPECT_EQ(pos, c.size()) << "bytes after the last entry";
    uint64_t off = 68 + frame_size;
    for (auto& e : out) {
        e.off = off;
        off += e.stored;
    }
    return out;
}

}  // namespace

TEST(TestVectors, DecodeToTheirStoredContents) {
    const bool regen = std::getenv("TETLOD_REGENERATE_VECTORS") != nullptr;
    for (const Vector& v : kVectors) {
        const std::string base = dir() + v.name;
        if (regen && v.current) {
            std::filesystem::create_directories(dir());
            Volume vol = vector_volume(v);
            if (v.max_error > 0) quantize_volume(vol, v.max_error);
            vol.field_name = "density";
            vol.units = "e/A^3";
            vol.spacing = {0.5, 1.0, 2.0};
            vol.origin = {-1.0, 0.0, 3.0};
            vol.metadata["sample.purpose"] = "tlod test vector";
            tlod::Metadata meta = tlod::metadata_for_volume(vol);
            meta.format_keys[tlod::kKeyConverter] = "tests/format/test_vectors.cpp";
            HtBuildOptions bo;
            bo.pad = v.pad;
            HtModel m = HtModel::build(vol, bo);
            HtEncodeOptions eo;
            eo.brick_log2 = 1;  // several bricks per cycle even at this size
            eo.chunk_mode = v.mode;
            eo.table = v.compact ? tlod::TableLayout::compact : tlod::TableLayout::full;
            eo.max_error = v.max_error;
            write_ht_container(base + ".tlod", m, meta, eo);
            write_file_atomic(base + ".raw", vol.data.data(), vol.data.size());
            auto r = tlod::ContainerReader::open(base + ".tlod");
            auto d = decode_ht(*r);
            ASSERT_TRUE(d.ok());
            write_file_atomic(base + ".errors.f32", d->errors.data(), d->errors.size() * 4);
            auto r2 = tlod::ContainerReader::open(base + ".tlod");
            auto lay = read_ht_layout(*r2);
            std::string js = expected_json(v, vol, lay->metadata, chunk_modes(*r2));
            write_file_atomic(base + ".json", js.data(), js.size());
        }
        if (!std::filesystem::exists(base + ".tlod")) GTEST_SKIP() << "no test vectors in " << dir();
        auto r = tlod::ContainerReader::open(base + ".tlod");
        ASSERT_TRUE(r.ok()) << r.failure().message;
        auto vol = decode_volume(*r);
        ASSERT_TRUE(vol.ok()) << vol.failure().message;
        auto raw = slurp(base + ".raw");
        ASSERT_EQ(raw.size(), vol->data.size()) << v.name;
        EXPECT_EQ(0, std::memcmp(raw.data(), vol->data.data(), raw.size())) << v.name;
        auto r2 = tlod::ContainerReader::open(base + ".tlod");
        auto d = decode_ht(*r2);
        ASSERT_TRUE(d.ok());
        auto errs = slurp(base + ".errors.f32");
        ASSERT_EQ(errs.size(), d->errors.size() * 4);
        EXPECT_EQ(0, std::memcmp(errs.data(), d->errors.data(), errs.size())) << v.name;
        // The stored bounds hold for the decoded field.
        HtBuildOptions bo;
        bo.pad = v.pad;
        HtModel exact = HtModel::build(*vol, bo);
        for (std::size_t i = 0; i < exact.diamond_errors().size(); ++i)
            ASSERT_GE(d->errors[i], exact.diamond_errors()[i]) << v.name << " point " << i;
    }
}

// The JSON beside each vector, read back and compared with values computed
// here without the code under test: the header and section table parsed by
// hand from the spec's byte layout (§3, §4), every checksum recomputed with
// xxHash itself, the METADATA section decompressed with zstd itself and parsed
// by hand (§5), the value range from the .raw file, the geometry and keys from
// what the generator above wrote.
TEST(TestVectors, JsonMatchesAnIndependentReading) {
    int checked = 0;
    for (const Vector& v : kVectors) {
        SCOPED_TRACE(v.name);
        const std::string base = dir() + v.name;
        if (!std::filesystem::exists(base + ".json")) continue;
        std::ifstream js(base + ".json");
        const nlohmann::json j = nlohmann::json::parse(js);
        const std::vector<char> fc = slurp(base + ".tlod");
        const auto* f = reinterpret_cast<const unsigned char*>(fc.data());
        auto le = [&](std::size_t off, int n) {
            uint64_t x = 0;
            for (int i = 0; i < n; ++i) x |= uint64_t(f[off + i]) << (8 * i);
            return x;
        };
        ASSERT_GE(fc.size(), 64u);
        const unsigned char magic[8] = {0x89, 'T', 'L', 'O', 'D', 0x0D, 0x0A, 0x1A};
        EXPECT_EQ(0, std::memcmp(f, magic, 8));
        const std::string version = std::to_string(le(8, 2)) + "." + std::to_string(le(10, 2));
        EXPECT_EQ(j["format_version"].get<std::string>(), version);
        EXPECT_EQ(le(12, 4), 64u);
        EXPECT_EQ(le(32, 8), fc.size());  // file size
        const uint64_t nsec = le(40, 4);
        EXPECT_EQ(le(44, 4), 48u);
        EXPECT_EQ(le(56, 8), XXH64(f, 56, 0));                // header checksum
        const bool compact = (le(16, 8) >> 3) & 1;           // required feature COMPACT_TABLE (3.2)
        EXPECT_EQ(compact, v.compact);
        const std::vector<Entry> entries = compact ? compact_entries(f, fc.size(), nsec) : full_entries(f, nsec);
        ASSERT_EQ(entries.size(), nsec);
        uint64_t next = entries.empty() ? fc.size() : entries[0].off;
        std::vector<unsigned char> metadata;
        std::map<std::string, std::map<std::string, int>> modes;  // 3.0: from the flags' bits 8-11
        for (uint64_t i = 0; i < nsec; ++i) {
            const Entry& en = entries[i];
            const uint64_t type = en.type, flags = en.flags, off = en.off, stored = en.stored, raw = en.raw;
            ASSERT_EQ(off, next) << "section " << i;
            ASSERT_LE(off + stored, fc.size());
            EXPECT_EQ(en.checksum, XXH64(f + off, stored, 0)) << "section " << i;
            if (type != 3 && type != 4) {
                EXPECT_EQ(en.arg0 | en.arg1, 0u) << "section " << i;
            } else if (i >= 3) {  // chunks in cycle order, coarse to fine (§6.3)
                EXPECT_LE(en.arg0, entries[i - 1].arg0) << "section " << i;
            }
            if (type == 1) {  // METADATA
                metadata.resize(raw);
                if (flags & 1)
                    ASSERT_EQ(ZSTD_decompress(metadata.data(), raw, f + off, stored), raw);
                else
                    std::memcpy(metadata.data(), f + off, raw);
            }
            if (le(8, 2) >= 3 && (type == 3 || type == 4)) {
                const char* names[] = {"range", "constant", "samples", "zero-residual", "lattice", "range-2d", "static", "range-exp"};
                const uint64_t mode = (flags >> 8) & 15;
                // lattice since 3.3, range-2d since 3.6, static since 3.7, range-exp since 3.8
                ASSERT_LT(mode, le(10, 2) >= 8 ? 8u : le(10, 2) >= 7 ? 7u : le(10, 2) >= 6 ? 6u : le(10, 2) >= 3 ? 5u : 4u) << "section " << i;
                if (v.mode == 7 && type == 4 && mode == 0)  // forced: range only for chunks without diamonds
                    EXPECT_EQ(stored, 0u) << "section " << i;
                if (mode == 7) {  // an error mode, stored raw, >= 6 bytes (E0 and a range stream)
                    EXPECT_EQ(type, 4u) << "section " << i;
                    EXPECT_EQ(flags & 1, 0u) << "section " << i;
                    EXPECT_GE(stored, 6u) << "section " << i;
                }
                if (mode == 6) {  // a field mode, stored raw, >= 19 bytes
                    EXPECT_EQ(type, 3u) << "section " << i;
                    EXPECT_EQ(flags & 1, 0u) << "section " << i;
                    EXPECT_GE(stored, 19u) << "section " << i;
                }
                if (mode == 5) {  // a field mode, stored raw, >= 5 bytes (the range rules)
                    EXPECT_EQ(type, 3u) << "section " << i;
                    EXPECT_EQ(flags & 1, 0u) << "section " << i;
                    EXPECT_GE(stored, 5u) << "section " << i;
                }
                if (mode == 4) {  // a field mode of LOSSY files (required bit 2), stored raw, >= 5 bytes
                    EXPECT_EQ(type, 3u) << "section " << i;
                    EXPECT_TRUE((le(16, 8) >> 2) & 1) << "section " << i;
                    EXPECT_EQ(flags & 1, 0u) << "section " << i;
                    EXPECT_GE(stored, 5u) << "section " << i;
                }
                ++modes[type == 3 ? "HT_FIELD" : "HT_ERRORS"][names[mode]];
                if (mode == 2) {  // samples: raw size = values x bytes, the frame's content size too
                    ASSERT_TRUE(flags & 1);
                    EXPECT_EQ(ZSTD_getFrameContentSize(f + off, stored), raw) << "section " << i;
                }
            } else {
                EXPECT_EQ(flags >> 2, 0u) << "section " << i;  // no mode bits before 3.0
            }
            next = off + stored;
        }
        EXPECT_EQ(next, fc.size());
        if (j.contains("chunk_modes")) {
            const auto expected = j["chunk_modes"].get<std::map<std::string, std::map<std::string, int>>>();
            EXPECT_EQ(modes, expected);
        }
        ASSERT_GE(metadata.size(), 88u);
        auto mle = [&](std::size_t off, int n) {
            uint64_t x = 0;
            for (int i = 0; i < n; ++i) x |= uint64_t(metadata[off + i]) << (8 * i);
            return x;
        };
        auto mf64 = [&](std::size_t off) {
            const uint64_t b = mle(off, 8);
            double d;
            std::memcpy(&d, &b, 8);
            return d;
        };
        const int64_t dims[3] = {int64_t(mle(0, 8)), int64_t(mle(8, 8)), int64_t(mle(16, 8))};
        EXPECT_EQ(dims[0], v.dims.x);
        EXPECT_EQ(dims[1], v.dims.y);
        EXPECT_EQ(dims[2], v.dims.z);
        for (int a = 0; a < 3; ++a) EXPECT_EQ(j["dims"][a].get<int64_t>(), dims[a]);
        EXPECT_EQ(mle(24, 1), uint64_t(v.type));
        EXPECT_EQ(j["value_type"].get<std::string>(), value_type_name(v.type));
        const double spacing[3] = {0.5, 1.0, 2.0}, origin[3] = {-1.0, 0.0, 3.0};  // as generated above
        for (int a = 0; a < 3; ++a) {
            EXPECT_EQ(mf64(32 + 8 * a), spacing[a]);
            EXPECT_EQ(mf64(56 + 8 * a), origin[a]);
            EXPECT_EQ(j["spacing"][a].get<double>(), spacing[a]);
            EXPECT_EQ(j["origin"][a].get<double>(), origin[a]);
        }
        // Value range from the raw samples.
        const std::vector<char> raw = slurp(base + ".raw");
        const std::size_t w = value_size(v.type);
        ASSERT_EQ(raw.size(), std::size_t(v.dims.count()) * w);
        double lo = INFINITY, hi = -INFINITY;
        for (std::size_t i = 0; i < raw.size(); i += w) {
            double x = 0;
            switch (v.type) {
                case ValueType::U8: x = static_cast<unsigned char>(raw[i]); break;
                case ValueType::I16: { int16_t t; std::memcpy(&t, &raw[i], 2); x = t; break; }
                case ValueType::U16: { uint16_t t; std::memcpy(&t, &raw[i], 2); x = t; break; }
                case ValueType::F32: { float t; std::memcpy(&t, &raw[i], 4); x = t; break; }
                default: FAIL() << "type not covered";
            }
            if (std::isnan(x)) continue;
            lo = std::min(lo, x);
            hi = std::max(hi, x);
        }
        EXPECT_EQ(mf64(80), lo);
        EXPECT_EQ(mf64(88), hi);
        EXPECT_EQ(j["value_range"][0].get<double>(), lo);
        EXPECT_EQ(j["value_range"][1].get<double>(), hi);
        EXPECT_EQ(j["padded"].get<bool>(), v.pad);
        EXPECT_EQ(j["format_keys"]["field.name"].get<std::string>(), "density");
        EXPECT_EQ(j["format_keys"]["field.units"].get<std::string>(), "e/A^3");
        EXPECT_EQ(j["user_keys"]["sample.purpose"].get<std::string>(), "tlod test vector");
        if (v.max_error > 0) {
            // 3.3 lattice vectors: field.max_error as written, and every decoded
            // sample (the .raw) on the lattice of §6.4 (mode 4 was forced on the
            // quantized field, so every field chunk could take it).
            const double e = std::strtod(j["format_keys"]["field.max_error"].get<std::string>().c_str(), nullptr);
            EXPECT_EQ(e, v.type == ValueType::F32 ? v.max_error : std::floor(v.max_error));
            const double s = spec_step(v.type, e);
            for (std::size_t i = 0; i < raw.size(); i += w) EXPECT_TRUE(spec_on_lattice(v.type, &raw[i], s)) << i;
            EXPECT_GT(modes["HT_FIELD"]["lattice"], 0);
        }
        if (v.mode == 5) {  // 3.6 vectors: range-2d on every field chunk with points
            EXPECT_EQ(le(10, 2), 6u);
            EXPECT_GT(modes["HT_FIELD"]["range-2d"], 0);
        }
        if (v.mode == 6) {  // 3.7 vectors: static on every field chunk with points
            EXPECT_EQ(le(10, 2), 7u);
            EXPECT_GT(modes["HT_FIELD"]["static"], 0);
        }
        if (v.mode == 7) {  // 3.8 vectors: range-exp on every error chunk with diamonds
            EXPECT_EQ(le(10, 2), 8u);
            EXPECT_GT(modes["HT_ERRORS"]["range-exp"], 0);
        }
        // Every key of the JSON is in the METADATA section, byte for byte.
        const std::string mtext(metadata.begin(), metadata.end());
        for (const char* list : {"format_keys", "user_keys"})
            for (const auto& [k, val] : j[list].items()) {
                EXPECT_NE(mtext.find(k + val.get<std::string>()), std::string::npos) << k;
            }
        ++checked;
    }
    EXPECT_EQ(checked, int(std::size(kVectors)));
}
