// The .tlod container: round trips for every value type (the same bytes and
// the same decode with 1 and 2 threads), and the edges of the stream (every
// prefix, single-bit flips, trailing bytes, hostile headers).
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;
using namespace tetlod::tlod;

namespace {

// The full table by default: the hostile-header tests below patch its 48-byte
// entries in place (the compact table has its own, test_compact_table.cpp).
std::vector<std::byte> small_file(ValueType t = ValueType::U8, Dims d = {9, 6, 5}, bool pad = false,
                                  TableLayout layout = TableLayout::full) {
    Volume v = tlodtest::make_volume(d, t, 7);
    v.metadata["user.note"] = "hello";
    Metadata meta = metadata_for_volume(v);
    meta.format_keys[kKeyConverter] = "test";
    HtBuildOptions bo;
    bo.pad = pad;
    HtModel m = HtModel::build(v, bo);
    ContainerWriter w;
    HtEncodeOptions eo;
    eo.zstd_level = 3;
    eo.table = layout;
    encode_ht(m, meta, w, eo);
    return w.finish();
}

Expected<Volume> decode_bytes(std::span<const std::byte> b) {
    auto r = ContainerReader::from_memory(b);
    if (!r) return r.failure();
    return decode_volume(*r);
}

// Decodes everything (field and errors), as verify does.
Expected<HtDecoded> decode_all(std::span<const std::byte> b) {
    auto r = ContainerReader::from_memory(b);
    if (!r) return r.failure();
    return decode_ht(*r);
}

// At most `threads` worker threads while alive (chunks of a cycle are encoded
// and decoded in parallel; the results must not depend on it).
tbb::global_control thread_limit(int threads) {
    return tbb::global_control(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
}

// Rewrites the header checksum after editing header bytes.
void reseal_header(std::vector<std::byte>& f) {
    store_le(f.data() + 56, checksum64(std::span<const std::byte>(f.data(), 56)), 8);
}
void reseal_table(std::vector<std::byte>& f) {
    const uint32_t n = uint32_t(load_le(f.data() + 40, 4));
    store_le(f.data() + 48, checksum64(std::span<const std::byte>(f.data() + 64, n * 48)), 8);
    reseal_header(f);
}

}  // namespace

class RoundTrip : public ::testing::TestWithParam<ValueType> {};

TEST_P(RoundTrip, BitExactForEveryValueType) {
    for (Dims d : {Dims{9, 6, 5}, Dims{2, 2, 2}, Dims{17, 17, 17}, Dims{33, 3, 20}}) {
        for (bool pad : {false, true}) {
            Volume v = tlodtest::make_volume(d, GetParam(), 11, /*specials=*/false);
            v.metadata["k"] = "v";
            HtBuildOptions bo;
            bo.pad = pad;
            HtModel m = HtModel::build(v, bo);
            HtEncodeOptions eo;
            eo.zstd_level = 1;
            eo.brick_log2 = 1;  // many bricks even on tiny grids
            std::vector<std::byte> bytes;
            for (int threads : {1, 2}) {
                const auto limit = thread_limit(threads);
                ContainerWriter w;
                encode_ht(m, metadata_for_volume(v), w, eo);
                auto b = w.finish();
                if (threads == 1) bytes = std::move(b);
                else ASSERT_TRUE(b == bytes) << "encoded bytes differ with 2 threads";
            }
            {
                // Field and errors decoded with 1 and 2 threads: identical.
                const auto one = [&] { const auto l = thread_limit(1); return decode_all(bytes); }();
                const auto two = [&] { const auto l = thread_limit(2); return decode_all(bytes); }();
                ASSERT_TRUE(one.ok() && two.ok());
                ASSERT_TRUE(one->field.data == two->field.data);
                ASSERT_EQ(one->errors.size(), two->errors.size());
                ASSERT_EQ(std::memcmp(one->errors.data(), two->errors.data(), one->errors.size() * sizeof(float)), 0);
            }
            auto back = decode_bytes(bytes);
            ASSERT_TRUE(back.ok()) << back.failure().message;
            ASSERT_EQ(back->dims, v.dims);
            ASSERT_EQ(back->type, v.type);
            ASSERT_EQ(back->data, v.data) << "dims " << d.x << "x" << d.y << "x" << d.z << " pad " << pad;
            EXPECT_EQ(back->metadata, v.metadata);
            // Errors: stored >= true, and tight.
            auto r = ContainerReader::from_memory(bytes);
            auto dec = decode_ht(*r);
            ASSERT_TRUE(dec.ok()) << dec.failure().message;
            const auto& te = m.diamond_errors();
            ASSERT_EQ(dec->errors.size(), te.size());
            for (std::size_t i = 0; i < te.size(); ++i) {
                if (std::isnan(te[i])) continue;
                ASSERT_GE(dec->errors[i], te[i]) << i;
                if (std::isfinite(te[i]) && te[i] > 0) {
                    ASSERT_LE(dec->errors[i], te[i] * (1.0f + 1.0f / 16) * 1.0001f);
                }
                if (te[i] == 0) {
                    ASSERT_EQ(dec->errors[i], 0.0f);
                }
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, RoundTrip,
                         ::testing::Values(ValueType::U8, ValueType::I8, ValueType::U16,
                                           ValueType::I16, ValueType::U32, ValueType::I32,
                                           ValueType::F32, ValueType::F64));

TEST_P(RoundTrip, SpecialFloatValuesAndExtremesBitExact) {
    // The HT builder refuses non-finite values, but the field codec must not
    // care: build the model from parts with any errors.
    Volume v = tlodtest::make_volume({12, 7, 9}, GetParam(), 5, /*specials=*/true);
    HtDomain d = HtDomain::for_dims(v.dims, false);
    ZeroedVector<float> e(std::size_t(v.count()), 1.5f);
    HtModel m = HtModel::from_parts(v, d, e);
    ContainerWriter w;
    encode_ht(m, metadata_for_volume(v), w);
    auto bytes = w.finish();
    for (int threads : {1, 2}) {
        const auto limit = thread_limit(threads);
        auto back = decode_bytes(bytes);
        ASSERT_TRUE(back.ok()) << back.failure().message;
        EXPECT_EQ(back->data, v.data) << threads << " threads";
    }
}

TEST(ErrorQuantizer, RoundsUpAndIsMonotone) {
    std::mt19937 rng(3);
    for (int m = 0; m <= 7; ++m) {
        EXPECT_EQ(dequantize_error(quantize_error(0.0f, m), m), 0.0f);
        EXPECT_TRUE(std::isinf(dequantize_error(quantize_error(INFINITY, m), m)));
        EXPECT_TRUE(std::isinf(dequantize_error(quantize_error(NAN, m), m)));
        EXPECT_TRUE(std::isinf(dequantize_error(quantize_error(std::numeric_limits<float>::max(), m), m)));
        for (int i = 0; i < 20000; ++i) {
            float e = std::ldexp(float(rng() % 100000) / 100000.0f, int(rng() % 60) - 30);
            float q = dequantize_error(quantize_error(e, m), m);
            ASSERT_GE(q, e);
            ASSERT_LE(q, e * (1.0f + std::ldexp(1.0f, -m)) + 1e-38f);
        }
    }
}

TEST(Metadata, RoundTripAndValidation) {
    Metadata m;
    m.dims = {3, 4, 5};
    m.type = ValueType::F32;
    m.spacing = {0.5, 1, 3.2};
    m.origin = {-1, 0, 7};
    m.value_range = {-2, 9};
    m.format_keys[kKeyFieldName] = "density";
    m.user_keys["a"] = std::string("x\0y", 3);
    m.user_keys["zz"] = "";
    auto raw = serialize_metadata(m);
    auto back = parse_metadata(raw);
    ASSERT_TRUE(back.ok()) << back.failure().message;
    EXPECT_EQ(back->dims, m.dims);
    EXPECT_EQ(back->spacing, m.spacing);
    EXPECT_EQ(back->user_keys, m.user_keys);
    for (std::size_t n = 0; n < raw.size(); ++n)
        EXPECT_FALSE(parse_metadata(std::span<const std::byte>(raw.data(), n)).ok()) << n;
    auto extra = raw;
    extra.push_back(std::byte{0});
    EXPECT_EQ(parse_metadata(extra).failure().code, ErrorCode::CorruptData);
    auto huge = raw;
    store_le(huge.data(), uint64_t{1} << 40, 8);  // dims.x = 2^40
    EXPECT_EQ(parse_metadata(huge).failure().code, ErrorCode::TooLarge);
}

TEST(Robustness, EveryPrefixFailsCleanly) {
    for (TableLayout layout : {TableLayout::full, TableLayout::compact}) {
        auto f = small_file(ValueType::U8, {9, 6, 5}, false, layout);
        for (std::size_t n = 0; n < f.size(); ++n) {
            auto r = decode_bytes(std::span<const std::byte>(f.data(), n));
            ASSERT_FALSE(r.ok()) << n;
            EXPECT_EQ(r.failure().code, ErrorCode::Truncated) << n << ": " << r.failure().message;
        }
        ASSERT_TRUE(decode_bytes(f).ok());
    }
}

TEST(Robustness, EverySingleBitFlipIsDetected) {
    for (TableLayout layout : {TableLayout::full, TableLayout::compact}) {
        auto f = small_file(ValueType::I16, {9, 6, 5}, false, layout);
        for (std::size_t i = 0; i < f.size(); ++i)
            for (int b = 0; b < 8; ++b) {
                auto g = f;
                g[i] ^= std::byte(1u << b);
                auto r = decode_all(g);
                ASSERT_FALSE(r.ok()) << "byte " << i << " bit " << b;
                const ErrorCode c = r.failure().code;
                // The file_size field: Truncated / trailing bytes. The compact
                // table's frame size (bytes 64-67) is checked against the file
                // before the table checksum: past the end, CorruptData.
                const bool size_field = (i >= 32 && i < 40) || (layout == TableLayout::compact && i >= 64 && i < 68);
                ASSERT_TRUE(c == ErrorCode::ChecksumMismatch || c == ErrorCode::BadMagic ||
                            (size_field && c == ErrorCode::CorruptData) || (i >= 32 && i < 40))
                    << "byte " << i << " bit " << b << ": " << r.failure().message;
            }
    }
}

// The same edges for a lossy file whose field chunks are all in the lattice
// mode (format 3.3, the spec's test vector): every prefix Truncated, every
// single bit flip caught by a checksum (or a size field).
TEST(Robustness, LatticeVectorPrefixesAndBitFlips) {
    const std::string path = std::string(TETLOD_SPEC_DIR) + "/test-vectors/ht_v3.3_f32_17x13x9_lattice.tlod";
    std::vector<std::byte> f;
    {
        std::FILE* fp = std::fopen(path.c_str(), "rb");
        ASSERT_NE(fp, nullptr);
        f.resize(4096);
        f.resize(std::fread(f.data(), 1, f.size(), fp));
        std::fclose(fp);
    }
    ASSERT_TRUE(decode_all(f).ok());
    for (std::size_t n = 0; n < f.size(); ++n) {
        auto r = decode_bytes(std::span<const std::byte>(f.data(), n));
        ASSERT_FALSE(r.ok()) << n;
        EXPECT_EQ(r.failure().code, ErrorCode::Truncated) << n << ": " << r.failure().message;
    }
    for (std::size_t i = 0; i < f.size(); ++i)
        for (int b = 0; b < 8; ++b) {
            auto g = f;
            g[i] ^= std::byte(1u << b);
            auto r = decode_all(g);
            ASSERT_FALSE(r.ok()) << "byte " << i << " bit " << b;
            const ErrorCode c = r.failure().code;
            const bool size_field = (i >= 32 && i < 40) || (i >= 64 && i < 68);
            ASSERT_TRUE(c == ErrorCode::ChecksumMismatch || c == ErrorCode::BadMagic ||
                        (size_field && (c == ErrorCode::CorruptData || c == ErrorCode::Truncated)))
                << "byte " << i << " bit " << b << ": " << r.failure().message;
        }
}

TEST(Robustness, TrailingBytesRefused) {
    auto f = small_file();
    f.push_back(std::byte{0});
    auto r = decode_bytes(f);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.failure().code, ErrorCode::CorruptData);
    EXPECT_NE(r.failure().message.find("trailing"), std::string::npos);
}

TEST(Robustness, HostileHeaders) {
    auto f = small_file();
    {  // a section count whose table would pass the end of the file
        auto g = f;
        store_le(g.data() + 40, 0x7FFFFFFF, 4);
        reseal_header(g);
        auto r = ContainerReader::from_memory(g);
        ASSERT_FALSE(r.ok());
        EXPECT_EQ(r.failure().code, ErrorCode::CorruptData);
    }
    {  // a section size past the end of the file
        auto g = f;
        store_le(g.data() + 64 + 48 * 2 + 16, uint64_t{1} << 50, 8);
        reseal_table(g);
        auto r = ContainerReader::from_memory(g);
        ASSERT_FALSE(r.ok());
        EXPECT_EQ(r.failure().code, ErrorCode::CorruptData);
    }
    {  // an impossible raw size (decompression bomb claim)
        auto g = f;
        store_le(g.data() + 64 + 48 * 2 + 24, uint64_t{1} << 50, 8);
        reseal_table(g);
        EXPECT_EQ(ContainerReader::from_memory(g).failure().code, ErrorCode::CorruptData);
    }
    {  // newer major version
        auto g = f;
        store_le(g.data() + 8, tlod::kVersionMajor + 1, 2);
        reseal_header(g);
        EXPECT_EQ(ContainerReader::from_memory(g).failure().code, ErrorCode::UnsupportedVersion);
    }
    {  // unknown required feature
        auto g = f;
        store_le(g.data() + 16, 0x21, 8);  // bit 5: not defined (bit 2 LOSSY since 3.1, 3 COMPACT_TABLE since 3.2, 4 LOSSY_MT since 3.5)
        reseal_header(g);
        EXPECT_EQ(ContainerReader::from_memory(g).failure().code, ErrorCode::UnsupportedFeature);
    }
    {  // LOSSY (3.1) without its field.max_error key: the HT is refused, never read as lossless
        auto g = f;
        store_le(g.data() + 16, 0x5, 8);
        reseal_header(g);
        auto r = ContainerReader::from_memory(g);
        ASSERT_TRUE(r.ok());
        EXPECT_EQ(decode_volume(*r).failure().code, ErrorCode::CorruptData);
    }
    {  // unknown optional feature: accepted
        auto g = f;
        store_le(g.data() + 24, 0x80, 8);
        reseal_header(g);
        auto r = ContainerReader::from_memory(g);
        ASSERT_TRUE(r.ok());
        EXPECT_TRUE(decode_volume(*r).ok());
    }
    {  // dims of 2^40 in METADATA, with valid checksums: refused before allocating
        Metadata m;
        m.dims = {int64_t{1} << 40, 2, 2};
        // The writer refuses to write it (its reader would refuse it) ...
        try {
            (void)serialize_metadata(m);
            ADD_FAILURE() << "serialize_metadata wrote dims of 2^40";
        } catch (const Error& e) {
            EXPECT_EQ(e.code(), ErrorCode::TooLarge) << e.what();
        }
        // ... so the hostile section is patched by hand (dims x is the first u64).
        m.dims = {2, 2, 2};
        auto raw = serialize_metadata(m);
        store_le(raw.data(), uint64_t{1} << 40, 8);
        ContainerWriter w;
        w.set_features(kFeatureHt);
        w.add(kSectionMetadata, kSectionCritical, 0, 0, raw, 1);
        auto g = w.finish();
        auto r = ContainerReader::from_memory(g);
        ASSERT_TRUE(r.ok());
        auto d = decode_volume(*r);
        ASSERT_FALSE(d.ok());
        EXPECT_EQ(d.failure().code, ErrorCode::TooLarge);
    }
}

TEST(Sections, UnknownOptionalSkippedUnknownCriticalRefused) {
    Volume v = tlodtest::make_volume({5, 5, 5}, ValueType::U16, 1);
    HtModel m = HtModel::build(v);
    for (uint32_t flags : {0u, kSectionCritical}) {
        ContainerWriter w;
        encode_ht(m, metadata_for_volume(v), w);
        std::vector<std::byte> junk(10, std::byte{0x5a});
        w.add_stored(999, flags, 1, 2, junk, junk.size());
        auto f = w.finish();
        auto r = ContainerReader::from_memory(f);
        if (flags == 0) {
            ASSERT_TRUE(r.ok()) << r.failure().message;
            auto back = decode_volume(*r);
            ASSERT_TRUE(back.ok()) << back.failure().message;
            EXPECT_EQ(back->data, v.data);
        } else {
            ASSERT_FALSE(r.ok());
            EXPECT_EQ(r.failure().code, ErrorCode::UnsupportedFeature);
        }
    }
}

TEST(Lazy, CoarseLodReadsAPrefix) {
    Volume v = tlodtest::make_volume({65, 65, 65}, ValueType::U16, 5);
    HtModel m = HtModel::build(v);
    ContainerWriter w;
    HtEncodeOptions eo;
    eo.zstd_level = 3;
    encode_ht(m, metadata_for_volume(v), w, eo);
    auto f = w.finish();
    auto r = ContainerReader::from_memory(f);
    ASSERT_TRUE(r.ok());
    HtDecodeRequest q;
    q.finest_cycle = 3;
    auto d = decode_ht(*r, q);
    ASSERT_TRUE(d.ok()) << d.failure().message;
    EXPECT_LT(r->bytes_read(), f.size() / 10);
    // The decoded points are exact.
    for (int64_t z = 0; z <= 64; z += 8)
        for (int64_t y = 0; y <= 64; y += 8)
            for (int64_t x = 0; x <= 64; x += 8)
                ASSERT_EQ(d->field.value(x, y, z), v.value(x, y, z));
    // A small box at full resolution.
    auto r2 = ContainerReader::from_memory(f);
    HtDecodeRequest b;
    b.box = std::array<int64_t, 6>{10, 10, 10, 14, 14, 14};
    auto d2 = decode_ht(*r2, b);
    ASSERT_TRUE(d2.ok());
    EXPECT_LT(r2->bytes_read(), f.size() / 2);
    EXPECT_LE(r2->distinct_bytes_read(), r2->bytes_read());
    // A section read again counts again in bytes_read, once in distinct_bytes_read.
    auto r3 = ContainerReader::from_memory(f);
    const uint64_t head = r3->distinct_bytes_read();
    EXPECT_EQ(head, r3->bytes_read());
    ASSERT_TRUE(r3->read_stored(0).ok());
    ASSERT_TRUE(r3->read_stored(0).ok());
    EXPECT_EQ(r3->bytes_read(), head + 2 * r3->sections()[0].stored_size);
    EXPECT_EQ(r3->distinct_bytes_read(), head + r3->sections()[0].stored_size);
    for (int64_t z = 10; z <= 14; ++z)
        for (int64_t y = 10; y <= 14; ++y)
            for (int64_t x = 10; x <= 14; ++x) ASSERT_EQ(d2->field.value(x, y, z), v.value(x, y, z));
}

// Lazy extraction from a container must give exactly the mesh of the fully
// decoded model (same stored bounds), for uniform, box and isovalue queries,
// while decoding fewer chunks for coarse or local queries.
TEST(LazyExtract, SameMeshAsFullDecode) {
    Volume v = tlodtest::make_volume({33, 29, 31}, ValueType::U16, 5);
    HtModel built = HtModel::build(v);
    ContainerWriter w;
    HtEncodeOptions eo;
    eo.brick_log2 = 1;
    encode_ht(built, metadata_for_volume(v), w, eo);
    const auto file = w.finish();
    auto rf = ContainerReader::from_memory(file);
    auto full = decode_ht(*rf);
    ASSERT_TRUE(full.ok());
    HtModel ref = HtModel::from_parts(full->field, full->layout.domain, full->errors, full->layout.max_error);
    const double range = ref.value_range()[1] - ref.value_range()[0];
    std::vector<LodQuery> qs(5);
    qs[0].error_in = 0.2 * range;
    qs[1].error_in = 0.01 * range;
    qs[2].error_in = 0.0;
    qs[3].box = std::array<int64_t, 6>{3, 4, 5, 9, 9, 9};
    qs[3].error_in = 0.0;
    qs[3].error_out = 0.3 * range;
    qs[4].isovalues = {ref.value_range()[0] + 0.5 * range};
    qs[4].error_in = 0.02 * range;
    qs[4].error_out = 0.5 * range;
    for (std::size_t i = 0; i < qs.size(); ++i) {
        TetMesh want = ref.extract(qs[i]);
        auto r = ContainerReader::from_memory(file);
        HtLazyStats st;
        auto got = extract_ht_lazy(*r, qs[i], nullptr, &st);
        ASSERT_TRUE(got.ok()) << got.failure().message;
        EXPECT_EQ(got->points, want.points) << "query " << i;
        EXPECT_EQ(got->tets, want.tets) << "query " << i;
        EXPECT_EQ(got->values, want.values) << "query " << i;
        EXPECT_EQ(got->error, want.error) << "query " << i;
        if (i == 0 || i == 3) {
            EXPECT_LT(st.chunks_decoded, st.chunks_total) << "query " << i;
        }
    }
}

// give_up_at: encode_ht stops once its chunk sections alone reach the limit
// (the file cannot then be smaller), and a limit it stays under changes nothing.
TEST(EncodeHt, GivesUpOnlyWhenTheFileCannotStayUnderTheLimit) {
    const Volume v = tlodtest::make_volume(Dims{33, 29, 31}, ValueType::U16, 11);
    const HtModel m = HtModel::build(v);
    const Metadata meta = metadata_for_volume(v);
    HtEncodeOptions eo;
    eo.zstd_level = 3;
    ContainerWriter full;
    ASSERT_TRUE(encode_ht(m, meta, full, eo));
    const std::vector<std::byte> reference = full.finish();
    uint64_t chunk_bytes = 0;
    const auto reader = ContainerReader::from_memory(reference);
    ASSERT_TRUE(reader);
    for (const SectionInfo& s : reader->sections())
        if (s.type == kSectionHtField || s.type == kSectionHtErrors) chunk_bytes += s.stored_size;
    ASSERT_GT(chunk_bytes, 1000u);
    // Just above what the chunks take: completes, same bytes.
    eo.give_up_at = chunk_bytes + 1;
    ContainerWriter under;
    EXPECT_TRUE(encode_ht(m, meta, under, eo));
    EXPECT_TRUE(under.finish() == reference);
    // At what the chunks take, or below: the file would reach it, so it gives up.
    for (uint64_t limit : {chunk_bytes, chunk_bytes / 2, uint64_t{1}}) {
        eo.give_up_at = limit;
        ContainerWriter w;
        EXPECT_FALSE(encode_ht(m, meta, w, eo)) << limit;
    }
}
