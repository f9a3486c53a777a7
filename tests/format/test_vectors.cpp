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
#include <sstream>

#include "tetlod/codec/ht/ht_codec.hpp"
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
    /// vectors stand; the 2.1 MT vectors are in test_mt_container.cpp.)
    bool current;
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
};

std::string dir() { return std::string(TETLOD_SPEC_DIR) + "/test-vectors/"; }

std::vector<char> slurp(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string expected_json(const Vector& v, const Volume& vol, const tlod::Metadata& m) {
    std::ostringstream o;
    o.precision(17);
    o << "{\n  \"file\": \"" << v.name << ".tlod\",\n  \"format_version\": \"" << (v.current ? "2.0" : "1.0") << "\",\n"
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
    o << "\n  }\n}\n";
    return o.str();
}

}  // namespace

TEST(TestVectors, DecodeToTheirStoredContents) {
    const bool regen = std::getenv("TETLOD_REGENERATE_VECTORS") != nullptr;
    for (const Vector& v : kVectors) {
        const std::string base = dir() + v.name;
        if (regen && v.current) {
            std::filesystem::create_directories(dir());
            Volume vol = tlodtest::make_volume(v.dims, v.type, 42);
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
            write_ht_container(base + ".tlod", m, meta, eo);
            write_file_atomic(base + ".raw", vol.data.data(), vol.data.size());
            auto r = tlod::ContainerReader::open(base + ".tlod");
            auto d = decode_ht(*r);
            ASSERT_TRUE(d.ok());
            write_file_atomic(base + ".errors.f32", d->errors.data(), d->errors.size() * 4);
            auto r2 = tlod::ContainerReader::open(base + ".tlod");
            auto lay = read_ht_layout(*r2);
            std::string js = expected_json(v, vol, lay->metadata);
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
