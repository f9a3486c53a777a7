// Hostile format-2.0 streams (spec/tlod-format.md §6.3, §7.5, §9): files whose
// framing and checksums are valid but which break a 2.0 rule. Each must fail
// with the specific error, and the values-per-byte rule must stop a tiny file
// claiming a huge volume before the decoder allocates the field.
#include <gtest/gtest.h>

#include <string>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;
using namespace tetlod::tlod;

namespace {

struct V2Header {
    uint8_t k = 0, flags = 0, brick_log2 = 16, mantissa = 4, predictor = 2, coding = 2;
    uint32_t box[3] = {0, 0, 0};
};

std::vector<std::byte> ht_header(const V2Header& h) {
    std::vector<std::byte> b;
    for (uint8_t v : {h.k, h.flags, h.brick_log2, h.mantissa, h.predictor, h.coding}) put_u8(b, v);
    put_u16(b, 0);
    for (uint32_t v : h.box) put_u32(b, v);
    put_u32(b, 0);
    return b;
}

/// A cube volume of n^3 u8 samples, n = 2^k + 1, one brick per cycle (g = 16),
/// every chunk section `section_bytes` long (a well-formed range-coder prefix:
/// a 0 byte then zeros). Checksums all valid.
std::vector<std::byte> claim_cube(int k, std::size_t section_bytes, uint32_t field_flags = kSectionCritical) {
    const int64_t n = (int64_t{1} << k) + 1;
    Metadata m;
    m.dims = {n, n, n};
    m.type = ValueType::U8;
    V2Header h;
    h.k = uint8_t(k);
    for (auto& b : h.box) b = uint32_t(n - 1);
    ContainerWriter w;
    w.set_table(TableLayout::full);  // patched through its 48-byte entries
    w.set_features(kFeatureHt);
    w.add(kSectionMetadata, kSectionCritical, 0, 0, serialize_metadata(m), 1);
    const auto hh = ht_header(h);
    w.add_stored(kSectionHtHeader, kSectionCritical, 0, 0, hh, hh.size());
    for (int t = k; t >= 0; --t) {
        std::vector<std::byte> s(section_bytes, std::byte{0});
        w.add_stored(kSectionHtField, field_flags, uint32_t(t), 0, s, s.size());
        // The corner cycle has no diamonds: its error section is empty.
        std::vector<std::byte> e(t == k ? 0 : section_bytes, std::byte{0});
        w.add_stored(kSectionHtErrors, kSectionCritical, uint32_t(t), 0, e, e.size());
    }
    return w.finish();
}

Failure layout_failure(std::span<const std::byte> f) {
    auto r = ContainerReader::from_memory(f);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.failure().message);
    if (!r) return r.failure();
    auto L = read_ht_layout(*r);
    EXPECT_FALSE(L.ok());
    return L ? Failure{ErrorCode::Ok, {}} : L.failure();
}

Failure decode_failure(std::span<const std::byte> f) {
    auto r = ContainerReader::from_memory(f);
    if (!r) return r.failure();
    auto d = decode_ht(*r);
    EXPECT_FALSE(d.ok());
    return d ? Failure{ErrorCode::Ok, {}} : d.failure();
}

std::vector<std::byte> small_v2(ValueType t = ValueType::U8) {
    Volume v = tlodtest::make_volume({9, 6, 5}, t, 7);
    HtModel m = HtModel::build(v);
    ContainerWriter w;
    HtEncodeOptions o;
    o.chunk_mode = 0;  // range mode wherever possible: these tests are about its rules
    o.table = TableLayout::full;  // the tests patch sections through the 48-byte entries
    encode_ht(m, metadata_for_volume(v), w, o);
    return w.finish();
}

/// Index of the first table entry of `type` with a non-empty section.
std::size_t first_nonempty(std::span<const std::byte> f, uint32_t type) {
    const uint32_t n = uint32_t(load_le(f.data() + 40, 4));
    for (uint32_t i = 0; i < n; ++i) {
        const std::byte* e = f.data() + 64 + 48 * i;
        if (load_le(e, 4) == type && load_le(e + 16, 8) > 0) return i;
    }
    return n;
}

void reseal_table(std::vector<std::byte>& f) {
    const uint32_t n = uint32_t(load_le(f.data() + 40, 4));
    store_le(f.data() + 48, checksum64(std::span<const std::byte>(f.data() + 64, n * 48)), 8);
    store_le(f.data() + 56, checksum64(std::span<const std::byte>(f.data(), 56)), 8);
}

void reseal_section(std::vector<std::byte>& f, std::size_t i) {
    std::byte* e = f.data() + 64 + 48 * i;
    const uint64_t off = load_le(e + 8, 8), size = load_le(e + 16, 8);
    store_le(e + 40, checksum64(std::span<const std::byte>(f.data() + off, size)), 8);
    reseal_table(f);
}

}  // namespace

TEST(HostileV2, ValuesPerByteLimitRefusedBeforeAllocating) {
    // 1025^3 u8 claimed by a file of a few hundred bytes: decoding would need a
    // 1 GiB field; the cycle-0 chunk's 939 million values cannot fit in 5 bytes.
    const auto f = claim_cube(10, 5);
    ASSERT_LT(f.size(), 2000u);
    const Failure lf = layout_failure(f);
    EXPECT_EQ(lf.code, ErrorCode::CorruptData);
    EXPECT_NE(lf.message.find("cannot fit"), std::string::npos) << lf.message;
    // decode_ht reads the layout before any allocation, so it fails the same way.
    const Failure df = decode_failure(f);
    EXPECT_EQ(df.code, ErrorCode::CorruptData);
    EXPECT_NE(df.message.find("cannot fit"), std::string::npos) << df.message;
}

TEST(HostileV2, ValuesPerByteLimitIsExact) {
    // k = 2 (5^3): the cycle-0 chunk has 125 - 27 = 98 points. With S = 5 bytes
    // every chunk passes the 8192·S bound; the streams are then refused as
    // malformed, not by the size rule.
    const auto f = claim_cube(2, 5);
    auto r = ContainerReader::from_memory(f);
    ASSERT_TRUE(r.ok());
    EXPECT_TRUE(read_ht_layout(*r).ok());
    EXPECT_EQ(decode_failure(f).code, ErrorCode::CorruptData);
}

TEST(HostileV2, ShortOrMisplacedStreamsRefused) {
    {  // a non-empty chunk with a stream shorter than the 5-byte minimum
        const Failure lf = layout_failure(claim_cube(3, 4));
        EXPECT_EQ(lf.code, ErrorCode::CorruptData);
        EXPECT_NE(lf.message.find("impossible"), std::string::npos) << lf.message;
    }
    {  // zstd on a range-coded section
        const Failure lf = layout_failure(claim_cube(3, 8, kSectionCritical | kSectionZstd));
        EXPECT_EQ(lf.code, ErrorCode::CorruptData);
    }
}

TEST(HostileV2, HeaderRulesRefused) {
    const auto base = small_v2();
    const std::size_t hh = first_nonempty(base, kSectionHtHeader);
    const uint64_t off = load_le(base.data() + 64 + 48 * hh + 8, 8);
    struct Case { std::size_t byte; uint8_t value; ErrorCode code; };
    const Case cases[] = {
        {4, 2, ErrorCode::Ok},                     // (2, 2): unchanged, valid
        {5, 1, ErrorCode::UnsupportedFeature},     // predictor 2 with coding 1
        {4, 3, ErrorCode::UnsupportedFeature},     // unknown predictor
        {1, 2, ErrorCode::CorruptData},            // reserved HT flag bit
        {6, 1, ErrorCode::CorruptData},            // reserved field
        {2, 0, ErrorCode::CorruptData},            // brick log2 0
        {3, 8, ErrorCode::CorruptData},            // 8 mantissa bits
        {0, 9, ErrorCode::CorruptData},            // k not matching the dims
    };
    for (const Case& c : cases) {
        auto g = base;
        g[off + c.byte] = std::byte{c.value};
        reseal_section(g, hh);
        auto r = ContainerReader::from_memory(g);
        ASSERT_TRUE(r.ok());
        auto L = read_ht_layout(*r);
        if (c.code == ErrorCode::Ok) {
            EXPECT_TRUE(L.ok());
        } else {
            ASSERT_FALSE(L.ok()) << "byte " << c.byte;
            EXPECT_EQ(L.failure().code, c.code) << "byte " << c.byte << ": " << L.failure().message;
        }
    }
}

TEST(HostileV2, StreamRulesRefused) {
    const auto base = small_v2(ValueType::I16);
    const std::size_t fs = first_nonempty(base, kSectionHtField);
    const std::byte* e = base.data() + 64 + 48 * fs;
    const uint64_t off = load_le(e + 8, 8);
    {  // first byte of a range-coded stream must be 0
        auto g = base;
        g[off] = std::byte{1};
        reseal_section(g, fs);
        EXPECT_EQ(decode_failure(g).code, ErrorCode::CorruptData);
    }
    {  // the stored size must match the checksum-covered bytes: a valid file
       // with one section's checksum wrong is a ChecksumMismatch
        auto g = base;
        g[off + 1] ^= std::byte{0x10};
        auto r = ContainerReader::from_memory(g);
        ASSERT_TRUE(r.ok());
        EXPECT_EQ(decode_ht(*r).failure().code, ErrorCode::ChecksumMismatch);
    }
    {  // the ZSTD flag on a range-coded error section of a real file
        const std::size_t es = first_nonempty(base, kSectionHtErrors);
        auto g = base;
        std::byte* ee = g.data() + 64 + 48 * es;
        store_le(ee + 4, load_le(ee + 4, 4) | kSectionZstd, 4);
        reseal_table(g);
        const Failure lf = layout_failure(g);
        EXPECT_EQ(lf.code, ErrorCode::CorruptData);
        EXPECT_NE(lf.message.find("zstd"), std::string::npos) << lf.message;
    }
}
