// The compact section table of format 3.2 (spec/tlod-format.md §4.4): round
// trips against the full table (the same SectionInfos, the same section bytes,
// the same decode), and hostile tables (built by hand with valid checksums so
// that each reaches the rule it breaks), each refused with its own error.
#include <algorithm>
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <zstd.h>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;
using namespace tetlod::tlod;

namespace {

std::vector<std::byte> ht_file(TableLayout layout, uint64_t extra_features = 0) {
    Volume v = tlodtest::make_volume({17, 9, 6}, ValueType::I16, 3);
    HtModel m = HtModel::build(v);
    ContainerWriter w;
    HtEncodeOptions eo;
    eo.zstd_level = 3;
    eo.brick_log2 = 1;
    eo.table = layout;
    encode_ht(m, metadata_for_volume(v), w, eo);
    if (extra_features) w.set_features(kFeatureHt | extra_features);
    return w.finish();
}

// The sections of two readers agree in everything but where they start.
void expect_same_sections(ContainerReader& a, ContainerReader& b) {
    ASSERT_EQ(a.sections().size(), b.sections().size());
    for (std::size_t i = 0; i < a.sections().size(); ++i) {
        const SectionInfo &x = a.sections()[i], &y = b.sections()[i];
        EXPECT_EQ(x.type, y.type) << i;
        EXPECT_EQ(x.flags, y.flags) << i;
        EXPECT_EQ(x.stored_size, y.stored_size) << i;
        EXPECT_EQ(x.raw_size, y.raw_size) << i;
        EXPECT_EQ(x.arg0, y.arg0) << i;
        EXPECT_EQ(x.arg1, y.arg1) << i;
        EXPECT_EQ(x.checksum, y.checksum) << i;
        EXPECT_EQ(x.offset - a.sections()[0].offset, y.offset - b.sections()[0].offset) << i;
        auto sx = a.read_stored(i), sy = b.read_stored(i);
        ASSERT_TRUE(sx && sy) << i;
        EXPECT_TRUE(*sx == *sy) << i;
    }
}

void put_varint(std::vector<std::byte>& out, uint64_t v) {
    while (v >= 0x80) {
        out.push_back(std::byte(uint8_t(v | 0x80)));
        v >>= 7;
    }
    out.push_back(std::byte(uint8_t(v)));
}

/// A 3.2 file from a hand-made table content (what the frame expands to), its
/// section count and the sections' bytes, every checksum valid.
std::vector<std::byte> compact_file(const std::vector<std::byte>& content, uint32_t count,
                                    const std::vector<std::byte>& payload = {}) {
    std::vector<std::byte> frame(ZSTD_compressBound(content.size()));
    frame.resize(ZSTD_compress(frame.data(), frame.size(), content.data(), content.size(), 3));
    std::vector<std::byte> table;
    put_u32(table, uint32_t(frame.size()));
    table.insert(table.end(), frame.begin(), frame.end());
    std::vector<std::byte> f;
    for (unsigned char c : kMagic) put_u8(f, c);
    put_u16(f, 3);
    put_u16(f, 2);
    put_u32(f, 64);
    put_u64(f, kFeatureHt | kFeatureCompactTable);
    put_u64(f, 0);
    put_u64(f, 64 + table.size() + payload.size());
    put_u32(f, count);
    put_u32(f, 48);
    put_u64(f, checksum64(table));
    put_u64(f, checksum64(f));
    f.insert(f.end(), table.begin(), table.end());
    f.insert(f.end(), payload.begin(), payload.end());
    return f;
}

/// The content of one stored (not zstd) section of `size` bytes of type 99.
std::vector<std::byte> one_entry(uint64_t size, uint64_t checksum) {
    std::vector<std::byte> c;
    put_varint(c, 99);  // type: unknown, not critical
    put_varint(c, 0);   // flags
    put_varint(c, 0);   // arg0 delta
    put_varint(c, 0);   // arg1 delta
    put_varint(c, size);
    if (size) put_u64(c, checksum);
    return c;
}

Failure refusal(const std::vector<std::byte>& f) {
    auto r = ContainerReader::from_memory(f);
    EXPECT_FALSE(r.ok());
    return r ? Failure{ErrorCode::Ok, ""} : r.failure();
}

void expect_refused(const std::vector<std::byte>& f, ErrorCode code, const std::string& words) {
    const Failure e = refusal(f);
    EXPECT_EQ(e.code, code) << e.message;
    EXPECT_NE(e.message.find(words), std::string::npos) << e.message;
}

}  // namespace

TEST(CompactTable, SameSectionsAndDecodeAsTheFullTable) {
    const auto full = ht_file(TableLayout::full), compact = ht_file(TableLayout::compact);
    EXPECT_LT(compact.size(), full.size());
    auto a = ContainerReader::from_memory(full), b = ContainerReader::from_memory(compact);
    ASSERT_TRUE(a.ok() && b.ok()) << b.failure().message;
    EXPECT_EQ(a->table_layout(), TableLayout::full);
    EXPECT_EQ(b->table_layout(), TableLayout::compact);
    // Full: a 3.0 file, as before 3.2; compact: 3.2. Either says 3.6 when a
    // field chunk uses the range-2d mode (spec §6.4), 3.8 when an error chunk
    // uses range-exp, the newer features (the encoder's options, not the table's).
    auto uses = [](const ContainerReader& r, uint32_t mode) {
        return std::any_of(r.sections().begin(), r.sections().end(),
                           [&](const SectionInfo& s) { return section_mode(s.flags) == mode; });
    };
    EXPECT_EQ(a->header().version_minor, uses(*a, 7) ? 8 : uses(*a, 5) ? 6 : 0);
    EXPECT_EQ(b->header().version_minor, uses(*b, 7) ? 8 : uses(*b, 5) ? 6 : 2);
    EXPECT_EQ(a->table_bytes(), 48 * a->sections().size());
    EXPECT_EQ(b->table_bytes(), b->sections()[0].offset - 64);
    EXPECT_EQ(b->bytes_read(), 64 + b->table_bytes());
    EXPECT_EQ(b->header().required_features, kFeatureHt | kFeatureCompactTable);
    expect_same_sections(*a, *b);
    auto da = decode_ht(*a), db = decode_ht(*b);
    ASSERT_TRUE(da.ok() && db.ok());
    EXPECT_EQ(da->field.data, db->field.data);
    ASSERT_EQ(da->errors.size(), db->errors.size());
    EXPECT_EQ(0, std::memcmp(da->errors.data(), db->errors.data(), da->errors.size() * sizeof(float)));
}

TEST(CompactTable, LossyAndMtFilesSayTheirVersion) {
    // Lossy: 3.2 with the compact table (it includes 3.1), 3.1 with the full one.
    for (TableLayout t : {TableLayout::compact, TableLayout::full}) {
        ContainerWriter w;
        w.set_table(t);
        w.set_features(kFeatureHt | kFeatureLossy);
        w.add_stored(99, 0, 0, 0, std::vector<std::byte>(3, std::byte{1}), 3);
        auto f = w.finish();
        auto r = ContainerReader::from_memory(f);
        ASSERT_TRUE(r.ok()) << r.failure().message;
        EXPECT_EQ(r->header().version_minor, t == TableLayout::compact ? 2 : 1);
    }
    // HT + MT and MT-only files: the same sections under both layouts.
    Volume v = tlodtest::make_volume({7, 6, 5}, ValueType::U8, 2);
    const MtModel mt = MtModel::build(v);
    const Metadata meta = metadata_for_volume(v);
    for (bool with_ht : {true, false}) {
        std::vector<std::byte> files[2];
        for (int i = 0; i < 2; ++i) {
            ContainerWriter w;
            if (with_ht) {
                HtEncodeOptions eo;
                eo.table = i ? TableLayout::full : TableLayout::compact;
                encode_ht(HtModel::build(v), meta, w, eo);
            }
            w.set_table(i ? TableLayout::full : TableLayout::compact);
            encode_mt_container(mt, meta, w, with_ht);
            files[i] = w.finish();
        }
        auto a = ContainerReader::from_memory(files[1]), b = ContainerReader::from_memory(files[0]);
        ASSERT_TRUE(a.ok() && b.ok()) << b.failure().message;
        expect_same_sections(*a, *b);
        auto la = read_mt_layout(*a), lb = read_mt_layout(*b);
        ASSERT_TRUE(la.ok() && lb.ok()) << lb.failure().message;
    }
}

TEST(CompactTable, ManySectionsEmptyOnesAndEveryFieldWidth) {
    std::mt19937_64 rng(5);
    ContainerWriter full, compact;
    full.set_table(TableLayout::full);
    full.set_features(kFeatureHt);
    compact.set_features(kFeatureHt);
    for (int i = 0; i < 3000; ++i) {
        const uint32_t type = i % 7 == 0 ? 0xFFFFFFFFu : uint32_t(100 + rng() % 5);
        const uint64_t size = i % 3 == 0 ? 0 : rng() % 40;
        std::vector<std::byte> bytes(size);
        for (auto& b : bytes) b = std::byte(uint8_t(rng()));
        // Arguments jump anywhere in u32 (the deltas wrap), raw sizes up to u64-ish.
        const uint32_t a0 = i % 5 == 0 ? uint32_t(rng()) : uint32_t(i / 10), a1 = uint32_t(rng() >> (rng() % 33));
        const bool z = i % 4 == 1;
        const uint64_t raw = z ? rng() % (size * 32768 + 131072) : size;
        full.add_stored(type, z ? kSectionZstd : 0, a0, a1, bytes, raw);
        compact.add_stored(type, z ? kSectionZstd : 0, a0, a1, bytes, raw);
    }
    const auto ff = full.finish(), fc = compact.finish();
    EXPECT_EQ(fc.size(), compact.file_size());
    auto a = ContainerReader::from_memory(ff), b = ContainerReader::from_memory(fc);
    ASSERT_TRUE(a.ok() && b.ok()) << b.failure().message;
    expect_same_sections(*a, *b);
    const auto offsets = compact.section_offsets();
    for (std::size_t i = 0; i < offsets.size(); ++i) EXPECT_EQ(offsets[i], b->sections()[i].offset);
    // No sections at all.
    ContainerWriter none;
    auto empty = none.finish();
    auto r = ContainerReader::from_memory(empty);
    ASSERT_TRUE(r.ok()) << r.failure().message;
    EXPECT_TRUE(r->sections().empty());
}

TEST(CompactTable, LeadingBytesAndOffsetsOfADistributedWriter) {
    // The distributed writer writes leading_bytes() at 0 and each external
    // section at its offset: the result must be the file finish() writes.
    ContainerWriter local, dist;
    std::vector<std::vector<std::byte>> parts;
    for (int i = 0; i < 20; ++i) parts.push_back(std::vector<std::byte>(std::size_t(i * 3), std::byte(uint8_t(i))));
    for (ContainerWriter* w : {&local, &dist}) {
        w->set_features(kFeatureHt);
        w->add_stored(kSectionMetadata, kSectionCritical, 0, 0, parts[1], parts[1].size());
    }
    for (int i = 2; i < 20; ++i) {
        local.add_stored(100, 0, uint32_t(i), 0, parts[std::size_t(i)], parts[std::size_t(i)].size());
        dist.add_external(100, 0, uint32_t(i), 0, parts[std::size_t(i)].size(), parts[std::size_t(i)].size(),
                          checksum64(parts[std::size_t(i)]));
    }
    const auto want = local.finish();
    std::vector<std::byte> got = dist.leading_bytes();
    got.resize(dist.file_size());
    const auto offsets = dist.section_offsets();
    for (int i = 2; i < 20; ++i)
        std::copy(parts[std::size_t(i)].begin(), parts[std::size_t(i)].end(), got.begin() + int64_t(offsets[std::size_t(i - 1)]));
    EXPECT_TRUE(got == want);
}

TEST(CompactTable, AReaderOf31RefusesItAsAnUnsupportedFeature) {
    // What a 3.0/3.1 reader does with the header (spec 3.1 §4.1, in its order):
    // magic, header checksum, major, Header_Size and Table_Entry_Size, then the
    // required features it knows (HT, MT, LOSSY). Table_Entry_Size stays 48 in
    // a 3.2 file precisely so that this reader reaches the feature check.
    const auto f = ht_file(TableLayout::compact);
    auto reader_31 = [](const std::vector<std::byte>& g) {
        if (std::memcmp(g.data(), kMagic, 8) != 0) return ErrorCode::BadMagic;
        if (load_le(g.data() + 56, 8) != checksum64(std::span<const std::byte>(g.data(), 56)))
            return ErrorCode::ChecksumMismatch;
        if (load_le(g.data() + 8, 2) > 3) return ErrorCode::UnsupportedVersion;
        if (load_le(g.data() + 12, 4) != 64 || load_le(g.data() + 44, 4) != 48) return ErrorCode::CorruptData;
        if (load_le(g.data() + 16, 8) & ~uint64_t{0x7}) return ErrorCode::UnsupportedFeature;
        return ErrorCode::Ok;
    };
    EXPECT_EQ(reader_31(f), ErrorCode::UnsupportedFeature);
    EXPECT_EQ(reader_31(ht_file(TableLayout::full)), ErrorCode::Ok);
    // And this reader refuses a required bit it does not know in the same way.
    auto g = f;
    store_le(g.data() + 16, load_le(g.data() + 16, 8) | (uint64_t{1} << 5), 8);  // bit 4 is LOSSY_MT (3.5)
    store_le(g.data() + 56, checksum64(std::span<const std::byte>(g.data(), 56)), 8);
    EXPECT_EQ(ContainerReader::from_memory(g).failure().code, ErrorCode::UnsupportedFeature);
}

TEST(CompactTable, EveryPrefixAndTrailingByteRefused) {
    const auto f = ht_file(TableLayout::compact);
    for (std::size_t n = 0; n < f.size(); ++n) {
        auto r = ContainerReader::from_memory(std::span<const std::byte>(f.data(), n));
        ASSERT_FALSE(r.ok()) << n;
        EXPECT_EQ(r.failure().code, ErrorCode::Truncated) << n;
    }
    auto g = f;
    g.push_back(std::byte{0});
    expect_refused(g, ErrorCode::CorruptData, "trailing");
}

TEST(CompactTable, EverySingleBitFlipOfTheTableIsCaughtOrConsistent) {
    const auto f = ht_file(TableLayout::compact);
    auto r0 = ContainerReader::from_memory(f);
    ASSERT_TRUE(r0.ok());
    const std::size_t table_end = std::size_t(r0->sections()[0].offset);
    for (std::size_t i = 64; i < table_end; ++i)
        for (int b = 0; b < 8; ++b) {
            auto g = f;
            g[i] ^= std::byte(uint8_t(1u << b));
            // As stored: the table checksum catches it (a frame size past the
            // end of the file is refused before, as CorruptData).
            const ErrorCode stored = ContainerReader::from_memory(g).failure().code;
            EXPECT_TRUE(stored == ErrorCode::ChecksumMismatch || (i < 68 && stored == ErrorCode::CorruptData))
                << i << ":" << b;
            // Resealed (what a fuzzing build sees): refused cleanly, or a table
            // whose sections tile the file exactly. A flip in the frame size
            // moves the table's end (past the file: refused before the checksum).
            const std::size_t end = std::min<std::size_t>(g.size(), 68 + std::size_t(load_le(g.data() + 64, 4)));
            store_le(g.data() + 48, checksum64(std::span<const std::byte>(g.data() + 64, end - 64)), 8);
            store_le(g.data() + 56, checksum64(std::span<const std::byte>(g.data(), 56)), 8);
            auto r = ContainerReader::from_memory(g);
            if (!r.ok()) {
                const ErrorCode c = r.failure().code;
                EXPECT_TRUE(c == ErrorCode::CorruptData || c == ErrorCode::UnsupportedFeature || c == ErrorCode::TooLarge)
                    << i << ":" << b << " " << r.failure().message;
                continue;
            }
            uint64_t next = r->sections().empty() ? g.size() : r->sections()[0].offset;
            for (const SectionInfo& s : r->sections()) {
                EXPECT_EQ(s.offset, next);
                next = s.offset + s.stored_size;
            }
            EXPECT_EQ(next, g.size());
        }
}

TEST(CompactTable, HostileTablesRefusedWithTheirError) {
    const std::vector<std::byte> payload{std::byte{1}, std::byte{2}, std::byte{3}};
    const uint64_t sum = checksum64(payload);
    // The hand-made file itself is sound.
    {
        const auto good = compact_file(one_entry(3, sum), 1, payload);  // must outlive the reader
        auto r = ContainerReader::from_memory(good);
        ASSERT_TRUE(r.ok()) << r.failure().message;
        ASSERT_EQ(r->sections().size(), 1u);
        EXPECT_EQ(r->sections()[0].type, 99u);
        EXPECT_TRUE(r->read_section(0).ok());
        auto bad = compact_file(one_entry(3, sum ^ 1), 1, payload);
        auto rb = ContainerReader::from_memory(bad);
        ASSERT_TRUE(rb.ok());
        EXPECT_EQ(rb->read_section(0).failure().code, ErrorCode::ChecksumMismatch);  // per-section integrity
    }
    // A huge section count in a tiny file: refused before decompressing.
    expect_refused(compact_file(one_entry(3, sum), 0xFFFFFFFFu, payload), ErrorCode::CorruptData, "sections claimed");
    // More sections than the content can hold (5 bytes an entry at least), or fewer.
    expect_refused(compact_file(one_entry(3, sum), 3, payload), ErrorCode::CorruptData, "cannot hold");
    // Content longer than 48 bytes an entry.
    {
        auto c = one_entry(3, sum);
        c.resize(60, std::byte{0});
        expect_refused(compact_file(c, 1, payload), ErrorCode::CorruptData, "at most 48");
    }
    // Bytes left after the last entry.
    {
        auto c = one_entry(3, sum);
        c.push_back(std::byte{0});
        expect_refused(compact_file(c, 1, payload), ErrorCode::CorruptData, "after the last entry");
    }
    // Bad varints (as the type): too long for a u32, overflowing it, not in shortest form.
    for (auto [bytes, words] : std::vector<std::pair<std::vector<uint8_t>, const char*>>{
             {{0x80, 0x80, 0x80, 0x80, 0x80, 0x01}, "longer than its field"},
             {{0xFF, 0xFF, 0xFF, 0xFF, 0x10}, "overflows"},
             {{0xE3, 0x00}, "shortest form"}}) {
        std::vector<std::byte> c;
        for (uint8_t x : bytes) c.push_back(std::byte(x));
        for (int i = 0; i < 4; ++i) c.push_back(std::byte{0});  // flags, args, an empty section
        expect_refused(compact_file(c, 1, {}), ErrorCode::CorruptData, words);
    }
    {  // the content ends inside the stored size
        const std::vector<std::byte> c{std::byte{99}, std::byte{0}, std::byte{0}, std::byte{0}, std::byte{0x83}};
        expect_refused(compact_file(c, 1, payload), ErrorCode::CorruptData, "ends inside a varint");
    }
    {  // a u64 stored size longer than 10 bytes
        std::vector<std::byte> c{std::byte{99}, std::byte{0}, std::byte{0}, std::byte{0}};
        for (int i = 0; i < 10; ++i) c.push_back(std::byte{0x80});
        c.push_back(std::byte{0x01});
        expect_refused(compact_file(c, 1, payload), ErrorCode::CorruptData, "longer than its field");
    }
    // Sizes whose sum overflows u64, a section past the end, sizes short of the file.
    {
        std::vector<std::byte> c;
        for (int i = 0; i < 2; ++i) put_varint(c, 99);
        for (int i = 0; i < 6; ++i) put_varint(c, 0);
        for (int i = 0; i < 2; ++i) put_varint(c, uint64_t{1} << 63);
        for (int i = 0; i < 2; ++i) put_u64(c, 0);
        expect_refused(compact_file(c, 2, payload), ErrorCode::CorruptData, "past the end of the file");
    }
    expect_refused(compact_file(one_entry(4, sum), 1, payload), ErrorCode::CorruptData, "past the end of the file");
    expect_refused(compact_file(one_entry(2, sum), 1, payload), ErrorCode::CorruptData, "between the last section");
    // The §4.2 rules of an entry: reserved flags, raw size, unknown critical type.
    {
        std::vector<std::byte> c;
        put_varint(c, 99), put_varint(c, 1u << 5), put_varint(c, 0), put_varint(c, 0), put_varint(c, 3);
        put_u64(c, sum);
        expect_refused(compact_file(c, 1, payload), ErrorCode::CorruptData, "reserved flag");
    }
    {
        std::vector<std::byte> c;
        put_varint(c, 99), put_varint(c, kSectionZstd), put_varint(c, 0), put_varint(c, 0), put_varint(c, 3);
        put_varint(c, uint64_t{1} << 40), put_u64(c, sum);
        expect_refused(compact_file(c, 1, payload), ErrorCode::CorruptData, "impossible");
    }
    {
        std::vector<std::byte> c;
        put_varint(c, 99), put_varint(c, kSectionCritical), put_varint(c, 0), put_varint(c, 0), put_varint(c, 3);
        put_u64(c, sum);
        expect_refused(compact_file(c, 1, payload), ErrorCode::UnsupportedFeature, "critical section");
    }
    // Not a zstd frame, a frame past the end of the file, a table checksum mismatch, major 2.
    {
        auto f = compact_file(one_entry(3, sum), 1, payload);
        f[68] ^= std::byte{0xFF};  // the frame's magic number
        store_le(f.data() + 48, checksum64(std::span<const std::byte>(f.data() + 64, f.size() - 64 - 3)), 8);
        store_le(f.data() + 56, checksum64(std::span<const std::byte>(f.data(), 56)), 8);
        expect_refused(f, ErrorCode::CorruptData, "zstd frame");
    }
    {
        auto f = compact_file(one_entry(3, sum), 1, payload);
        store_le(f.data() + 64, 1000, 4);
        expect_refused(f, ErrorCode::CorruptData, "extends past the end");
        auto g = compact_file(one_entry(3, sum), 1, payload);
        g[70] ^= std::byte{1};
        expect_refused(g, ErrorCode::ChecksumMismatch, "table checksum");
        auto h = compact_file(one_entry(3, sum), 1, payload);
        store_le(h.data() + 8, 2, 2);
        store_le(h.data() + 56, checksum64(std::span<const std::byte>(h.data(), 56)), 8);
        expect_refused(h, ErrorCode::CorruptData, "major version 2");
    }
}
