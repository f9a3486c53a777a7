// Format 3.0 chunk modes (spec/tlod-format.md §6.4): every value type through
// every mode bit-exact, the same bytes for any thread count, the encoder's
// choice on constant / sparse / linear volumes, and hostile mode sections.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "tetlod/codecs/error_quantizer.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "entropy/static_rans.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;
using namespace tetlod::tlod;

namespace {

tbb::global_control thread_limit(int threads) {
    return tbb::global_control(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
}

enum class Shape { Noisy, Constant, Sparse, Linear };

Volume make_shaped(Dims d, ValueType t, Shape s) {
    if (s == Shape::Noisy) return tlodtest::make_volume(d, t, 3);
    Volume v = Volume::allocate(d, t);
    dispatch_value_type(t, [&](auto tv) {
        using T = decltype(tv);
        T* p = v.as<T>();
        for (int64_t z = 0; z < d.z; ++z)
            for (int64_t y = 0; y < d.y; ++y)
                for (int64_t x = 0; x < d.x; ++x) {
                    int64_t val = 7;
                    if (s == Shape::Sparse) val = (x - 3) * (x - 3) + (y - 4) * (y - 4) + z * z < 9 ? 5 + x : 0;
                    if (s == Shape::Linear) val = x + 2 * y + 3 * z;  // every prediction exact in the interior
                    p[d.index(x, y, z)] = T(val);
                }
    });
    return v;
}

std::vector<std::byte> encode(const HtModel& m, const Volume& v, int mode, int threads = 1) {
    const auto limit = thread_limit(threads);
    HtEncodeOptions eo;
    eo.brick_log2 = 1;  // many chunks even on small grids
    eo.chunk_mode = mode;
    ContainerWriter w;
    encode_ht(m, metadata_for_volume(v), w, eo);
    return w.finish();
}

/// Sections per chunk mode (bits 8-11 of the flags), of one type.
std::array<int, 16> mode_counts(std::span<const std::byte> f, uint32_t type) {
    std::array<int, 16> n{};
    auto r = ContainerReader::from_memory(f);
    for (const auto& s : r->sections())
        if (s.type == type && s.stored_size + s.raw_size > 0) ++n[section_mode(s.flags)];
        else if (s.type == type && section_mode(s.flags) == 3) ++n[3];
    return n;
}

class ChunkModes : public ::testing::TestWithParam<ValueType> {};

}  // namespace

TEST_P(ChunkModes, EveryModeBitExact) {
    for (Shape shape : {Shape::Noisy, Shape::Constant, Shape::Sparse, Shape::Linear}) {
        for (int mode : {-1, 0, 1, 2, 3, 5, 6, 7}) {
            const Volume v = make_shaped({11, 9, 7}, GetParam(), shape);
            const HtModel m = HtModel::build(v);
            const auto bytes = encode(m, v, mode, 1);
            ASSERT_TRUE(bytes == encode(m, v, mode, 2)) << "bytes differ with 2 threads, mode " << mode;
            auto r = ContainerReader::from_memory(bytes);
            ASSERT_TRUE(r.ok());
            EXPECT_EQ(r->header().version_major, 3);
            auto dec = decode_ht(*r);
            ASSERT_TRUE(dec.ok()) << dec.failure().message;
            // The field on B: the volume itself (unpadded).
            ASSERT_EQ(dec->field.data, v.data) << "shape " << int(shape) << " mode " << mode;
            // Errors: exactly the stored bound of every diamond's error, whatever the mode.
            const auto& te = m.diamond_errors();
            ASSERT_EQ(dec->errors.size(), te.size());
            for (std::size_t i = 0; i < te.size(); ++i)
                ASSERT_EQ(dec->errors[i], dequantize_error(quantize_error(te[i], 4), 4))
                    << i << " shape " << int(shape) << " mode " << mode;
            const auto fm = mode_counts(bytes, kSectionHtField), em = mode_counts(bytes, kSectionHtErrors);
            if (mode == 2) EXPECT_GT(fm[2], 0);
            if (mode == 2) EXPECT_GT(em[2], 0);
            if (mode == 1 && shape == Shape::Constant) EXPECT_GT(fm[1] + em[1], 0);
            if (mode == 3 && shape == Shape::Linear) EXPECT_GT(fm[3], 0);
            if (mode == 0) EXPECT_EQ(fm[1] + fm[2] + fm[3] + fm[5] + fm[6] + em[1] + em[2] + em[7], 0);
            // Range-2d (format 3.6): every field chunk with points, never an error chunk.
            if (mode == 5) EXPECT_EQ(fm[0] + fm[1] + fm[2] + fm[3], 0);
            if (mode == 5) EXPECT_GT(fm[5], 0);
            EXPECT_EQ(em[5], 0);
            // Static (format 3.7): every field chunk with points, never an error chunk.
            if (mode == 6) EXPECT_EQ(fm[0] + fm[1] + fm[2] + fm[3] + fm[5], 0);
            if (mode == 6) EXPECT_GT(fm[6], 0);
            if (mode != 6) EXPECT_EQ(fm[6], 0);
            EXPECT_EQ(em[6], 0);
            // Range-exp (format 3.8): every error chunk with diamonds, never a field chunk;
            // by choice, where it is smaller than range.
            if (mode == 7) EXPECT_EQ(em[0] + em[1] + em[2], 0);
            if (mode == 7) EXPECT_GT(em[7], 0);
            if (mode != 7 && mode != -1) EXPECT_EQ(em[7], 0);
            EXPECT_EQ(fm[7], 0);
            EXPECT_EQ(r->header().version_minor, em[7] > 0 ? 8 : fm[6] > 0 ? 7 : fm[5] > 0 ? 6 : 2) << "mode " << mode;
            // (Error chunks at the far faces of B mix 0 with +inf bounds: range coded.)
            if (mode == -1 && shape == Shape::Constant) EXPECT_EQ(fm[0], 0);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, ChunkModes,
                         ::testing::Values(ValueType::U8, ValueType::I8, ValueType::U16, ValueType::I16,
                                           ValueType::U32, ValueType::I32, ValueType::F32, ValueType::F64));

TEST(ChunkModesChoice, SmallestNeverLargerThanRangeOnly) {
    for (Shape shape : {Shape::Noisy, Shape::Constant, Shape::Sparse, Shape::Linear}) {
        const Volume v = make_shaped({33, 33, 33}, ValueType::U8, shape);
        const HtModel m = HtModel::build(v);
        EXPECT_LE(encode(m, v, -1).size(), encode(m, v, 0).size()) << int(shape);
    }
}

// ---- hostile mode sections ----
namespace {

struct Section {
    SectionInfo info;
    std::vector<std::byte> bytes;
};

std::vector<Section> sections_of(std::span<const std::byte> f) {
    auto r = ContainerReader::from_memory(f);
    std::vector<Section> out;
    for (std::size_t i = 0; i < r->sections().size(); ++i) out.push_back({r->sections()[i], *r->read_stored(i)});
    return out;
}

std::vector<std::byte> rebuild(const std::vector<Section>& ss) {
    ContainerWriter w;
    w.set_features(kFeatureHt);
    for (const auto& s : ss) w.add_stored(s.info.type, s.info.flags, s.info.arg0, s.info.arg1, s.bytes, s.info.raw_size);
    return w.finish();
}

/// Index of the first section of `type` in `mode` with content.
std::size_t find_mode(const std::vector<Section>& ss, uint32_t type, uint32_t mode) {
    for (std::size_t i = 0; i < ss.size(); ++i)
        if (ss[i].info.type == type && section_mode(ss[i].info.flags) == mode && ss[i].info.raw_size > 0) return i;
    ADD_FAILURE() << "no section of type " << type << " in mode " << mode;
    return 0;
}

Failure open_failure(std::span<const std::byte> f) {
    auto r = ContainerReader::from_memory(f);
    if (!r) return r.failure();
    auto d = decode_ht(*r);
    return d ? Failure{ErrorCode::Ok, {}} : d.failure();
}

void set_mode(Section& s, uint32_t mode) { s.info.flags = (s.info.flags & ~kSectionModeMask) | (mode << kSectionModeShift); }

/// Random streams (every `whole_every`-th trial) and flipped bits in the section
/// `which(trial)` of `good`: a clean error or a decode, never a crash (run under
/// ASan / UBSan in the sanitizer build).
void expect_clean_on_damage(const std::vector<Section>& good, const std::function<std::size_t(int)>& which,
                            unsigned seed, int trials, int whole_every) {
    std::mt19937 rng(seed);
    for (int trial = 0; trial < trials; ++trial) {
        auto ss = good;
        auto& b = ss[which(trial)].bytes;
        if (trial % whole_every == 0) {
            for (auto& x : b) x = std::byte(rng() & 0xFF);
        } else {
            b[rng() % b.size()] ^= std::byte(1u << (rng() % 8));
        }
        const Failure f = open_failure(rebuild(ss));
        EXPECT_TRUE(f.code == ErrorCode::Ok || f.code == ErrorCode::CorruptData) << f.message;
    }
}

void expect_failure(const std::vector<Section>& ss, ErrorCode code, const std::string& text) {
    const Failure f = open_failure(rebuild(ss));
    EXPECT_EQ(f.code, code) << f.message;
    EXPECT_NE(f.message.find(text), std::string::npos) << f.message;
    EXPECT_NE(f.message.find("section"), std::string::npos) << f.message;
}

}  // namespace

TEST(ChunkModesHostile, RefusedWithSpecificErrors) {
    const Volume v = make_shaped({11, 9, 7}, ValueType::U16, Shape::Noisy);
    const HtModel m = HtModel::build(v);
    const auto samples = sections_of(encode(m, v, 2));
    const std::size_t fs = find_mode(samples, kSectionHtField, 2), es = find_mode(samples, kSectionHtErrors, 2);
    ASSERT_EQ(open_failure(rebuild(samples)).code, ErrorCode::Ok);
    {  // an unknown mode
        auto ss = samples;
        set_mode(ss[fs], 9);
        expect_failure(ss, ErrorCode::UnsupportedFeature, "unknown chunk mode 9");
    }
    {  // zero-residual is a field mode
        auto ss = samples;
        set_mode(ss[es], 3);
        ss[es].bytes.clear();
        ss[es].info.raw_size = 0;
        ss[es].info.flags &= ~kSectionZstd;
        expect_failure(ss, ErrorCode::UnsupportedFeature, "for error codes");
    }
    {  // a truncated zstd frame
        auto ss = samples;
        ss[fs].bytes.resize(ss[fs].bytes.size() - 3);
        expect_failure(ss, ErrorCode::CorruptData, "zstd");
    }
    {  // a raw size that is not the chunk's: refused before decompressing
        auto ss = samples;
        ss[fs].info.raw_size += 2;
        ss[fs].bytes = zstd_compress(std::vector<std::byte>(ss[fs].info.raw_size), 1);
        expect_failure(ss, ErrorCode::CorruptData, "samples chunk of");
    }
    {  // a frame declaring a content size other than the section's raw size
        auto ss = samples;
        ss[fs].bytes = zstd_compress(std::vector<std::byte>(ss[fs].info.raw_size - 2), 1);
        expect_failure(ss, ErrorCode::CorruptData, "content size");
    }
    {  // a huge claimed raw size: refused from the table, nothing allocated
        auto ss = samples;
        ss[fs].info.raw_size = uint64_t{1} << 40;
        const Failure f = open_failure(rebuild(ss));
        EXPECT_EQ(f.code, ErrorCode::CorruptData) << f.message;
    }
    {  // a constant field chunk of the wrong size, and one flagged ZSTD
        auto ss = samples;
        set_mode(ss[fs], 1);
        ss[fs].bytes.assign(3, std::byte{0});
        ss[fs].info.raw_size = 3;
        ss[fs].info.flags &= ~kSectionZstd;
        expect_failure(ss, ErrorCode::CorruptData, "constant chunk of 3 bytes");
        ss[fs].info.flags |= kSectionZstd;
        ss[fs].bytes = zstd_compress(std::vector<std::byte>(2), 1);
        ss[fs].info.raw_size = 2;
        expect_failure(ss, ErrorCode::CorruptData, "must not be zstd");
    }
    {  // a constant error chunk with a code above 0xFF << m
        auto ss = samples;
        set_mode(ss[es], 1);
        ss[es].bytes = {std::byte{0xFF}, std::byte{0xFF}};
        ss[es].info.raw_size = 2;
        ss[es].info.flags &= ~kSectionZstd;
        expect_failure(ss, ErrorCode::CorruptData, "error code above");
    }
    {  // a samples error chunk with a code above 0xFF << m
        auto ss = samples;
        std::vector<std::byte> codes(ss[es].info.raw_size, std::byte{0});
        codes[1] = std::byte{0xF0};
        ss[es].bytes = zstd_compress(codes, 1);
        expect_failure(ss, ErrorCode::CorruptData, "error code above");
    }
    {  // zero-residual with bytes; a mode on an empty chunk
        auto ss = samples;
        set_mode(ss[fs], 3);
        ss[fs].info.flags &= ~kSectionZstd;
        ss[fs].bytes.assign(4, std::byte{0});
        ss[fs].info.raw_size = 4;
        expect_failure(ss, ErrorCode::CorruptData, "zero-residual chunk with stored bytes");
        auto tt = samples;
        std::size_t empty = 0;
        for (std::size_t i = 0; i < tt.size(); ++i)
            if (tt[i].info.type == kSectionHtErrors && tt[i].info.raw_size == 0) empty = i;  // the corner chunk's
        ASSERT_NE(empty, 0u);
        set_mode(tt[empty], 1);
        expect_failure(tt, ErrorCode::CorruptData, "empty chunk");
    }
}

TEST(ChunkModesHostile, Range2dRefusedWithSpecificErrors) {
    const Volume v = make_shaped({11, 9, 7}, ValueType::I16, Shape::Noisy);
    const HtModel m = HtModel::build(v);
    const auto good = sections_of(encode(m, v, 5));
    const std::size_t fs = find_mode(good, kSectionHtField, 5);
    std::size_t es = 0;
    for (std::size_t i = 0; i < good.size(); ++i)
        if (good[i].info.type == kSectionHtErrors && good[i].info.raw_size > 0) es = i;
    ASSERT_NE(es, 0u);
    ASSERT_EQ(open_failure(rebuild(good)).code, ErrorCode::Ok);
    {  // a field mode: refused on an error chunk
        auto ss = good;
        set_mode(ss[es], 5);
        ss[es].info.flags &= ~kSectionZstd;
        expect_failure(ss, ErrorCode::UnsupportedFeature, "unknown chunk mode 5 for error codes");
    }
    {  // flagged ZSTD
        auto ss = good;
        ss[fs].info.flags |= kSectionZstd;
        ss[fs].bytes = zstd_compress(ss[fs].bytes, 1);
        expect_failure(ss, ErrorCode::CorruptData, "must not be zstd");
    }
    {  // too short for any stream: the range rules, from the table
        auto ss = good;
        ss[fs].bytes.resize(3);
        ss[fs].info.raw_size = 3;
        expect_failure(ss, ErrorCode::CorruptData, "coded size 3");
    }
    {  // truncated by one byte: the stream does not end at its last byte
        auto ss = good;
        ss[fs].bytes.pop_back();
        ss[fs].info.raw_size -= 1;
        EXPECT_EQ(open_failure(rebuild(ss)).code, ErrorCode::CorruptData);
    }
    {  // mode 0's contexts read from mode 5's stream (the largest chunk: in a small one
       // every point may meet a fresh model under either set, and decode the same)
        auto ss = good;
        std::size_t big = fs;
        for (std::size_t i = 0; i < ss.size(); ++i)
            if (ss[i].info.type == kSectionHtField && ss[i].info.raw_size > ss[big].info.raw_size) big = i;
        ASSERT_EQ(section_mode(ss[big].info.flags), 5u);
        set_mode(ss[big], 0);
        const Failure f = open_failure(rebuild(ss));
        if (f.code == ErrorCode::Ok) {
            const auto bytes = rebuild(ss);  // alive as long as the reader
            auto r = ContainerReader::from_memory(bytes);
            EXPECT_NE(decode_ht(*r)->field.data, v.data);
        } else {
            EXPECT_EQ(f.code, ErrorCode::CorruptData) << f.message;
        }
    }
    // Random streams and flipped bits: a clean error or a decode, never a crash.
    expect_clean_on_damage(good, [&](int) { return fs; }, 11, 200, 2);
}

TEST(ChunkModesHostile, StaticRefusedWithSpecificErrors) {
    const Volume v = make_shaped({11, 9, 7}, ValueType::I16, Shape::Noisy);
    const HtModel m = HtModel::build(v);
    const auto good = sections_of(encode(m, v, 6));
    const std::size_t fs = find_mode(good, kSectionHtField, 6);
    std::size_t es = 0;
    for (std::size_t i = 0; i < good.size(); ++i)
        if (good[i].info.type == kSectionHtErrors && good[i].info.raw_size > 0) es = i;
    ASSERT_NE(es, 0u);
    // The largest static section (the first may be a one-point chunk of 19 bytes).
    std::size_t big = fs;
    for (std::size_t i = 0; i < good.size(); ++i)
        if (good[i].info.type == kSectionHtField && good[i].info.raw_size > good[big].info.raw_size) big = i;
    ASSERT_EQ(section_mode(good[big].info.flags), 6u);
    ASSERT_GT(good[big].info.raw_size, 40u);
    ASSERT_EQ(open_failure(rebuild(good)).code, ErrorCode::Ok) << open_failure(rebuild(good)).message;
    {  // a field mode: refused on an error chunk
        auto ss = good;
        set_mode(ss[es], 6);
        ss[es].info.flags &= ~kSectionZstd;
        expect_failure(ss, ErrorCode::UnsupportedFeature, "unknown chunk mode 6 for error codes");
    }
    {  // mode 8 is not defined
        auto ss = good;
        set_mode(ss[fs], 8);
        expect_failure(ss, ErrorCode::UnsupportedFeature, "unknown chunk mode 8");
    }
    {  // flagged ZSTD
        auto ss = good;
        ss[fs].info.flags |= kSectionZstd;
        ss[fs].bytes = zstd_compress(ss[fs].bytes, 1);
        expect_failure(ss, ErrorCode::CorruptData, "must not be zstd");
    }
    {  // shorter than any static section, from the table
        auto ss = good;
        ss[fs].bytes.resize(18);
        ss[fs].info.raw_size = 18;
        expect_failure(ss, ErrorCode::CorruptData, "static chunk of 18 bytes");
    }
    {  // truncated by one byte: the raw bits do not end where they should
        auto ss = good;
        ss[big].bytes.pop_back();
        ss[big].info.raw_size -= 1;
        expect_failure(ss, ErrorCode::CorruptData, "malformed static");
    }
    {  // one byte too many
        auto ss = good;
        ss[big].bytes.push_back(std::byte{0});
        ss[big].info.raw_size += 1;
        expect_failure(ss, ErrorCode::CorruptData, "malformed static");
    }
    {  // a used table dropped: its points read the unused tables' block
        auto ss = good;
        std::array<rans::Frequencies, 64> tables;
        const auto taken = rans::read_tables(ss[big].bytes, 33, tables);  // i16: 2 * 16 + 1 symbols
        ASSERT_TRUE(taken.has_value());
        std::size_t used = 0;
        while (tables[used] == rans::Frequencies{}) ++used;
        tables[used] = rans::Frequencies{};
        std::vector<std::byte> bytes;
        rans::write_tables(tables, 33, bytes);
        bytes.insert(bytes.end(), ss[big].bytes.begin() + std::ptrdiff_t(*taken), ss[big].bytes.end());
        ss[big].bytes = bytes;
        ss[big].info.raw_size = bytes.size();
        expect_failure(ss, ErrorCode::CorruptData, "unused table");
    }
    {  // the range decoder reading a static stream
        auto ss = good;
        set_mode(ss[big], 0);
        const Failure f = open_failure(rebuild(ss));
        EXPECT_TRUE(f.code == ErrorCode::CorruptData || f.code == ErrorCode::Ok) << f.message;
    }
    // Random streams and flipped bits: a clean error or a decode, never a crash.
    expect_clean_on_damage(good, [&](int trial) { return trial % 2 ? big : fs; }, 13, 300, 3);
}

TEST(ChunkModesHostile, RangeExpRefusedWithSpecificErrors) {
    const Volume v = make_shaped({11, 9, 7}, ValueType::F32, Shape::Noisy);
    const HtModel m = HtModel::build(v);
    const auto good = sections_of(encode(m, v, 7));
    const std::size_t fs = find_mode(good, kSectionHtField, 0);
    std::size_t big = find_mode(good, kSectionHtErrors, 7);
    for (std::size_t i = 0; i < good.size(); ++i)
        if (good[i].info.type == kSectionHtErrors && good[i].info.raw_size > good[big].info.raw_size) big = i;
    ASSERT_EQ(section_mode(good[big].info.flags), 7u);
    ASSERT_GT(good[big].info.raw_size, 20u);
    ASSERT_EQ(open_failure(rebuild(good)).code, ErrorCode::Ok) << open_failure(rebuild(good)).message;
    auto decoded_errors = [&](const std::vector<Section>& ss) {
        const auto bytes = rebuild(ss);  // the reader reads from it: alive as long as the reader
        auto r = ContainerReader::from_memory(bytes);
        auto d = decode_ht(*r);
        return d ? std::vector<float>(d->errors.begin(), d->errors.end()) : std::vector<float>{};
    };
    const std::vector<float> errors = decoded_errors(good);
    {  // an error mode: refused on a field chunk
        auto ss = good;
        set_mode(ss[fs], 7);
        expect_failure(ss, ErrorCode::UnsupportedFeature, "unknown chunk mode 7 for field values");
    }
    {  // flagged ZSTD
        auto ss = good;
        ss[big].info.flags |= kSectionZstd;
        ss[big].bytes = zstd_compress(ss[big].bytes, 1);
        expect_failure(ss, ErrorCode::CorruptData, "must not be zstd");
    }
    {  // the base exponent alone: too short for a range stream, from the table
        auto ss = good;
        ss[big].bytes.resize(1);
        ss[big].info.raw_size = 1;
        expect_failure(ss, ErrorCode::CorruptData, "impossible");
    }
    {  // truncated by one byte, or one too many: the stream does not end at its last byte
        for (int more : {-1, 1}) {
            auto ss = good;
            if (more < 0) ss[big].bytes.pop_back();
            else ss[big].bytes.push_back(std::byte{0});
            ss[big].info.raw_size = ss[big].bytes.size();
            expect_failure(ss, ErrorCode::CorruptData, "malformed stream");
        }
    }
    {  // another base exponent: other contexts, a clean error or other bounds
        auto ss = good;
        ss[big].bytes[0] = std::byte(std::to_integer<int>(ss[big].bytes[0]) == 255 ? 0 : 255);
        const Failure f = open_failure(rebuild(ss));
        if (f.code == ErrorCode::Ok) EXPECT_NE(decoded_errors(ss), errors);
        else EXPECT_EQ(f.code, ErrorCode::CorruptData) << f.message;
    }
    {  // range mode's decoder reading a range-exp stream (its first byte is E0, not 0)
        auto ss = good;
        set_mode(ss[big], 0);
        const Failure f = open_failure(rebuild(ss));
        if (f.code == ErrorCode::Ok) EXPECT_NE(decoded_errors(ss), errors);
        else EXPECT_EQ(f.code, ErrorCode::CorruptData) << f.message;
    }
    {  // and the other way: range-exp's decoder on a range stream
        const auto range = sections_of(encode(m, v, 0));
        ASSERT_EQ(range.size(), good.size());
        auto ss = range;
        set_mode(ss[big], 7);
        const Failure f = open_failure(rebuild(ss));
        if (f.code == ErrorCode::Ok) EXPECT_NE(decoded_errors(ss), errors);
        else EXPECT_EQ(f.code, ErrorCode::CorruptData) << f.message;
    }
    // Random streams and flipped bits: a clean error or a decode, never a crash.
    expect_clean_on_damage(good, [&](int) { return big; }, 17, 300, 3);
}

TEST(ChunkModesChoice, RangeExpShrinksTheErrorsOfEveryType) {
    // The writer's choice against range alone for the error chunks (range_exp
    // off), on noisy volumes of every width: the same bounds back, fewer bytes.
    for (ValueType t : {ValueType::U8, ValueType::I16, ValueType::U32, ValueType::F32, ValueType::F64}) {
        const Volume v = make_shaped({33, 29, 25}, t, Shape::Noisy);
        const HtModel m = HtModel::build(v);
        auto errors_bytes = [&](bool range_exp, std::vector<float>& errors) {
            HtEncodeOptions eo;
            eo.brick_log2 = 2;
            eo.range_exp = range_exp;
            ContainerWriter w;
            encode_ht(m, metadata_for_volume(v), w, eo);
            const auto bytes = w.finish();
            auto r = ContainerReader::from_memory(bytes);
            uint64_t n = 0;
            for (const auto& s : r->sections())
                if (s.type == kSectionHtErrors) {
                    n += s.stored_size;
                    if (!range_exp) EXPECT_NE(section_mode(s.flags), 7u);
                }
            auto d = decode_ht(*r);
            EXPECT_TRUE(d.ok());
            if (d) errors.assign(d->errors.begin(), d->errors.end());
            return n;
        };
        std::vector<float> with, without;
        const uint64_t exp = errors_bytes(true, with), range = errors_bytes(false, without);
        EXPECT_LT(exp, range) << value_type_name(t);
        EXPECT_EQ(with, without) << value_type_name(t);
    }
}

TEST(ChunkModesChoice, FastDecodeUsesOnlyFastModesAndRoundTrips) {
    for (ValueType t : {ValueType::U8, ValueType::I16, ValueType::U32, ValueType::F32, ValueType::F64}) {
        for (Shape shape : {Shape::Noisy, Shape::Constant, Shape::Sparse, Shape::Linear}) {
            const Volume v = make_shaped({13, 10, 9}, t, shape);
            const HtModel m = HtModel::build(v);
            HtEncodeOptions eo;
            eo.brick_log2 = 1;
            eo.fast_decode = true;
            ContainerWriter w;
            encode_ht(m, metadata_for_volume(v), w, eo);
            const auto bytes = w.finish();
            const auto fm = mode_counts(bytes, kSectionHtField);
            EXPECT_EQ(fm[0] + fm[4] + fm[5], 0) << value_type_name(t) << " shape " << int(shape);
            auto r = ContainerReader::from_memory(bytes);
            ASSERT_TRUE(r.ok());
            const auto em = mode_counts(bytes, kSectionHtErrors);
            EXPECT_EQ(r->header().version_minor, em[7] > 0 ? 8 : fm[6] > 0 ? 7 : 2);
            auto dec = decode_ht(*r);
            ASSERT_TRUE(dec.ok()) << dec.failure().message;
            ASSERT_EQ(dec->field.data, v.data) << value_type_name(t) << " shape " << int(shape);
            if (shape == Shape::Constant) EXPECT_EQ(fm[6], 0);
            // Noise of 32 and 64 bits: static beats zstd of the samples somewhere
            // (on this small volume zstd wins every u8 and i16 chunk).
            if (shape == Shape::Noisy && (t == ValueType::U32 || t == ValueType::F32 || t == ValueType::F64))
                EXPECT_GT(fm[6], 0) << value_type_name(t);
        }
    }
    // The codec refuses static chunks with the full table (for readers older than 3.2).
    const Volume v = make_shaped({13, 10, 9}, ValueType::I16, Shape::Noisy);
    const HtModel m = HtModel::build(v);
    for (const bool forced : {false, true}) {
        HtEncodeOptions eo;
        eo.fast_decode = !forced;
        eo.chunk_mode = forced ? 6 : -1;
        eo.table = TableLayout::full;
        ContainerWriter w;
        EXPECT_THROW(encode_ht(m, metadata_for_volume(v), w, eo), Error);
    }
}

TEST(ChunkModesChoice, StaticCodesExtremeResidualsOfEveryWidth) {
    // Alternating extremes: residuals of every bit length up to the type's
    // width (every symbol of its alphabet) and the 24 + rest split of the widest.
    for (ValueType t : {ValueType::I8, ValueType::U16, ValueType::I32, ValueType::U32, ValueType::F32, ValueType::F64}) {
        Volume v = Volume::allocate({9, 8, 7}, t);
        std::mt19937_64 rng(5);
        dispatch_value_type(t, [&](auto tv) {
            using T = decltype(tv);
            T* p = v.as<T>();
            for (int64_t i = 0; i < v.count(); ++i) {
                if constexpr (std::is_floating_point_v<T>) {
                    // Finite values of every exponent (the HT needs finite values),
                    // the largest and zero among them.
                    const double mag = std::ldexp(double(rng() % 1000003), int(rng() % 200) - 100);
                    p[i] = i % 3 == 0 ? std::numeric_limits<T>::max() : i % 5 == 0 ? T(0) : T(rng() % 2 ? -mag : mag);
                } else {
                    uint64_t bits = rng();
                    if (i % 3 == 0) bits = ~uint64_t{0};
                    if (i % 5 == 0) bits = 0;
                    p[i] = T(bits >> (64 - 8 * sizeof(T)));
                }
            }
        });
        const HtModel m = HtModel::build(v);
        const auto bytes = encode(m, v, 6);
        auto r = ContainerReader::from_memory(bytes);
        ASSERT_TRUE(r.ok());
        auto dec = decode_ht(*r);
        ASSERT_TRUE(dec.ok()) << dec.failure().message;
        EXPECT_EQ(dec->field.data, v.data) << value_type_name(t);
        EXPECT_GT(mode_counts(bytes, kSectionHtField)[6], 0);
    }
}

TEST(ChunkModesHostile, ModeBitsRefusedBeforeVersion3) {
    // A 2.x file (the format 2.0 test vector) with a mode bit set: reserved bits.
    const std::string path = std::string(TETLOD_SPEC_DIR) + "/test-vectors/ht_v2_u8_9x6x5.tlod";
    auto r = ContainerReader::open(path);
    ASSERT_TRUE(r.ok());
    std::vector<std::byte> f(r->header().file_size);
    {
        FILE* fp = std::fopen(path.c_str(), "rb");
        ASSERT_EQ(std::fread(f.data(), 1, f.size(), fp), f.size());
        std::fclose(fp);
    }
    const uint32_t n = uint32_t(load_le(f.data() + 40, 4));
    for (uint32_t i = 0; i < n; ++i) {
        std::byte* e = f.data() + 64 + 48 * i;
        if (load_le(e, 4) == kSectionHtField) {
            store_le(e + 4, load_le(e + 4, 4) | (2u << kSectionModeShift), 4);
            break;
        }
    }
    store_le(f.data() + 48, checksum64(std::span<const std::byte>(f.data() + 64, n * 48)), 8);
    store_le(f.data() + 56, checksum64(std::span<const std::byte>(f.data(), 56)), 8);
    auto bad = ContainerReader::from_memory(f);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.failure().code, ErrorCode::CorruptData);
    EXPECT_NE(bad.failure().message.find("reserved flag bits"), std::string::npos) << bad.failure().message;
}
