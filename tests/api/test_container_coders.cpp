// Issue 13 Must 4: the coder of every section and its bytes, from the library
// (inspect_container / section_coders) without decoding anything. Checked
// against the section table itself: the rows partition the sections, so their
// bytes plus the header and table are exactly the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>

#include "tetlod/tetlod.hpp"

namespace {

namespace fs = std::filesystem;
using namespace tetlod;

std::string tmp(const std::string& name) { return std::string(TETLOD_TEST_TMP) + "/" + name; }

const SectionCoderInfo* row(const ContainerInfo& info, const std::string& section) {
    for (const auto& c : info.coders)
        if (c.section == section) return &c;
    return nullptr;
}

// Every section in exactly one row; bytes add up to the file.
void expect_partition(const ContainerInfo& info) {
    uint64_t count = 0, stored = 0;
    for (const auto& c : info.coders) {
        count += c.count;
        stored += c.stored_bytes;
        EXPECT_FALSE(c.description.empty()) << c.section;
    }
    EXPECT_EQ(count, info.sections.size());
    // Header and table: everything before the first section (either layout).
    const uint64_t framing = info.sections.empty() ? info.header.file_size : info.sections.front().offset;
    EXPECT_EQ(stored + framing, info.header.file_size);
    EXPECT_GT(framing, tlod::kHeaderSize);
}

}  // namespace

TEST(ContainerCoders, HtOnly) {
    const std::string path = tmp("coders_ht.tlod");
    write_container(make_sample_volume("sparse", Dims{33, 33, 33}), path);
    const ContainerInfo info = inspect_container(path).take();
    expect_partition(info);
    EXPECT_EQ(info.ht_residual_coding, 3);  // format 3.0: a mode per chunk section
    EXPECT_EQ(row(info, "METADATA")->coder, "zstd");
    EXPECT_EQ(row(info, "HT_HEADER")->coder, "stored");
    // One row per (section kind, chunk mode): the rows of a kind add up to its sections.
    uint64_t field_count = 0, error_count = 0, field_stored = 0, error_stored = 0, error_empty = 0;
    std::set<std::string> modes;
    for (const auto& c : info.coders) {
        if (c.section != "HT_FIELD" && c.section != "HT_ERRORS") {
            EXPECT_TRUE(c.mode.empty()) << c.section;
            continue;
        }
        EXPECT_FALSE(c.mode.empty()) << c.coder;
        modes.insert(c.mode);
        const bool field = c.section == "HT_FIELD";
        (field ? field_count : error_count) += c.count;
        (field ? field_stored : error_stored) += c.stored_bytes;
        if (!field) error_empty += c.empty;
    }
    // A sparse volume: zero chunks in a mode other than range.
    EXPECT_GE(modes.size(), 2u);
    EXPECT_TRUE(modes.count("range"));
    // One field and one error section per chunk; the corner chunk has no diamonds.
    EXPECT_EQ(field_count, error_count);
    EXPECT_GE(error_empty, 1u);
    uint64_t chunks = 0, field_bytes = 0, error_bytes = 0;
    for (const auto& c : info.ht->cycles) {
        chunks += c.chunks;
        field_bytes += c.field_bytes;
        error_bytes += c.error_bytes;
    }
    EXPECT_EQ(field_count, chunks);
    EXPECT_EQ(field_stored, field_bytes);
    EXPECT_EQ(error_stored, error_bytes);
    for (const auto& s : info.sections) {
        const std::string c = section_coder(s, info.ht_residual_coding);
        bool found = false;
        for (const auto& r : info.coders)
            found = found || (r.type == s.type && r.coder == c && r.mode == section_mode_name(s, 3));
        EXPECT_TRUE(found) << c;
    }
}

// Format 2.x (Residual_Coding 2): every chunk range coded, one row per kind.
TEST(ContainerCoders, Version2Range) {
    const std::string path = std::string(TETLOD_SPEC_DIR) + "/test-vectors/ht_v2_i16_17x17x17.tlod";
    const ContainerInfo info = inspect_container(path).take();
    expect_partition(info);
    EXPECT_EQ(info.ht_residual_coding, 2);
    ASSERT_EQ(info.coders.size(), 4u);
    EXPECT_EQ(row(info, "HT_FIELD")->coder, "ht-range-v2");
    EXPECT_EQ(row(info, "HT_ERRORS")->coder, "ht-range-v2");
    EXPECT_TRUE(row(info, "HT_FIELD")->mode.empty());
}

TEST(ContainerCoders, HtAndMt) {
    const std::string path = tmp("coders_both.tlod");
    ContainerWriteOptions o;
    o.mt = true;
    write_container(make_sample_volume("marschner-lobb", Dims{9, 9, 9}), path, o);
    const ContainerInfo info = inspect_container(path).take();
    expect_partition(info);
    ASSERT_GE(info.coders.size(), 6u);  // and one row per chunk mode used
    EXPECT_EQ(row(info, "MT_HEADER")->coder, "stored");
    EXPECT_EQ(row(info, "MT_HEADER")->count, 1u);
    EXPECT_EQ(row(info, "MT_STRUCTURE")->coder, "mt-zstd-payload");
    EXPECT_EQ(row(info, "MT_STRUCTURE")->stored_bytes, info.mt->structure_bytes);
}

// Format 1.0 (Residual_Coding 1): byte planes in zstd frames, named as such.
TEST(ContainerCoders, Version1Planes) {
    const std::string path = std::string(TETLOD_SPEC_DIR) + "/test-vectors/ht_v1_i16_17x17x17.tlod";
    const ContainerInfo info = inspect_container(path).take();
    expect_partition(info);
    EXPECT_EQ(info.ht_residual_coding, 1);
    EXPECT_EQ(row(info, "HT_FIELD")->coder, "ht-planes-v1+zstd");
    EXPECT_EQ(row(info, "HT_ERRORS")->coder, "ht-planes-v1+zstd");
    EXPECT_NE(row(info, "HT_FIELD")->description.find("§7.2"), std::string::npos);
}

TEST(ContainerCoders, Version3_3Lattice) {
    // Every field chunk of this vector is in the lattice mode (spec §6.4, format 3.3).
    const std::string path = std::string(TETLOD_SPEC_DIR) + "/test-vectors/ht_v3.3_f32_17x13x9_lattice.tlod";
    const ContainerInfo info = inspect_container(path).take();
    expect_partition(info);
    EXPECT_EQ(info.ht_residual_coding, 3);
    EXPECT_EQ(info.header.version_minor, 3);
    ASSERT_NE(row(info, "HT_FIELD"), nullptr);
    EXPECT_EQ(row(info, "HT_FIELD")->coder, "ht-lattice");
    EXPECT_EQ(row(info, "HT_FIELD")->mode, "lattice");
    EXPECT_NE(row(info, "HT_FIELD")->description.find("§6.4"), std::string::npos);
}

TEST(ContainerCoders, UnknownSectionsHaveTheirOwnRow) {
    std::vector<tlod::SectionInfo> secs(3);
    secs[0].type = tlod::kSectionMetadata;
    secs[0].flags = tlod::kSectionZstd | tlod::kSectionCritical;
    secs[0].stored_size = 10;
    secs[1].type = 99;
    secs[1].stored_size = 7;
    secs[2].type = 99;
    const auto rows = section_coders(secs, 0);
    ASSERT_EQ(rows.size(), 2u);
    EXPECT_EQ(rows[1].coder, "unknown");
    EXPECT_EQ(rows[1].count, 2u);
    EXPECT_EQ(rows[1].empty, 1u);
    EXPECT_EQ(rows[1].stored_bytes, 7u);
}

// ContainerWriteOptions::zstd_level is the level of every zstd frame, the HT
// chunks' fallback frames (samples mode) included: before, they stayed at 19
// whatever the level. Sparse balls make the fallback win on some field chunks.
TEST(ContainerCoders, ZstdLevelReachesTheChunkFrames) {
    const Volume v = make_sample_volume("sparse", Dims{65, 65, 65});
    uint64_t samples_bytes[2] = {0, 0};
    const int levels[2] = {1, 19};
    for (int i = 0; i < 2; ++i) {
        const std::string path = tmp("coders_level" + std::to_string(levels[i]) + ".tlod");
        ContainerWriteOptions o;
        o.zstd_level = levels[i];
        write_container(Volume(v), path, o);
        const ContainerInfo info = inspect_container(path).take();
        expect_partition(info);
        for (const auto& c : info.coders)
            if (c.mode == "samples") samples_bytes[i] += c.stored_bytes;
        EXPECT_TRUE(decode_container(path).take().data == v.data) << "level " << levels[i];
    }
    EXPECT_GT(samples_bytes[0], 0u);
    EXPECT_GT(samples_bytes[1], 0u);
    EXPECT_NE(samples_bytes[0], samples_bytes[1]) << "the chunk frames ignored the level";
}
