// MT serialization: round trips (decoded models pass the checker, re-encoding is
// byte-identical), determinism, and hostile bytes (every prefix, flipped bytes in
// the header and in the decompressed streams) failing cleanly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>

#include "mt_test_util.hpp"
#include "tetlod/codecs/error_quantizer.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/format/container.hpp"

namespace tetlod::test {
namespace {

struct Built {
    Volume vol;
    MtModel model;
};

Built build(Dims d, ValueType t, Field f) {
    Volume v = make_volume(d, t, f, 11);
    MtModel m = MtModel::build(v);
    return {std::move(v), std::move(m)};
}

TEST(MtCodec, RoundTripPassesTheChecker) {
    for (auto [d, t, f] : {std::tuple{Dims{9, 7, 5}, ValueType::U8, Field::Smooth},
                           std::tuple{Dims{6, 6, 6}, ValueType::F32, Field::Noisy},
                           std::tuple{Dims{10, 5, 8}, ValueType::I16, Field::Plateau}}) {
        SCOPED_TRACE(dims_str(d));
        const Built b = build(d, t, f);
        for (auto [with_field, coding] : {std::pair{false, 3}, std::pair{true, 3}, std::pair{false, 2}}) {
            SCOPED_TRACE("coding " + std::to_string(coding));
            MtEncodeOptions o;
            o.include_field = with_field;
            o.coding = coding;
            const auto bytes = encode_mt(b.model, o);
            EXPECT_EQ(bytes[4] | (bytes[5] << 8), coding);
            auto dec = decode_mt(bytes, with_field ? nullptr : &b.vol);
            ASSERT_TRUE(dec.ok()) << dec.failure().message;
            const MtModel& m = dec.value();
            EXPECT_EQ(m.updates().size(), b.model.updates().size());
            EXPECT_TRUE(m.base_tets() == b.model.base_tets());
            // Codings 2 and 3 hold the same model: labels, offsets, stars and
            // masks exactly, errors as the same upward codes.
            std::vector<size_t> original_of_w(size_t(b.vol.dims.count()), SIZE_MAX);
            for (size_t k = 0; k < b.model.updates().size(); ++k) original_of_w[b.model.updates()[k].w] = k;
            for (size_t k = 0; k < m.updates().size(); ++k) {
                const size_t j = original_of_w[m.updates()[k].w];
                ASSERT_NE(j, SIZE_MAX) << k;
                ASSERT_EQ(m.updates()[k].label, b.model.updates()[j].label) << k;
                ASSERT_EQ(m.survivor(k), b.model.survivor(j)) << k;
                ASSERT_EQ(m.updates()[k].star, b.model.updates()[j].star) << k;
                ASSERT_EQ(quantize_error(m.updates()[k].error, 7), quantize_error(b.model.updates()[j].error, 7)) << k;
            }
            EXPECT_TRUE(encode_mt(m, o) == bytes) << "re-encoding differs";
            const auto r = b.vol.range();
            std::vector<LodQuery> qs(4);
            qs[0].full = true;
            qs[1].error_in = 0.0;
            qs[2].error_in = 0.05 * (r[1] - r[0]);
            qs[3].error_in = 0.0, qs[3].error_out = 0.2 * (r[1] - r[0]);
            qs[3].box = std::array<int64_t, 6>{1, 1, 1, 3, 3, 3};
            for (const auto& q : qs) {
                SCOPED_TRACE(query_str(q));
                const TetMesh mesh = m.extract(q);
                if (q.full) {
                    EXPECT_EQ(int64_t(mesh.tet_count()), 5 * cells(d));
                }
                EXPECT_TRUE(mesh_ok(b.vol, mesh, mt_check_options(q, b.vol)));
            }
        }
    }
}

TEST(MtCodec, DeterministicBytes) {
    const Built a = build({8, 9, 7}, ValueType::U8, Field::Noisy);
    const Built b = build({8, 9, 7}, ValueType::U8, Field::Noisy);
    EXPECT_TRUE(encode_mt(a.model) == encode_mt(b.model));
}

// The bricked build merges bricks in a fixed order, so the container does not depend
// on how many threads decimated them.
TEST(MtCodec, SameBytesForAnyThreadCount) {
    for (auto [d, t, f, bricks] : {std::tuple{Dims{13, 11, 9}, ValueType::U8, Field::Noisy, 3},
                                   std::tuple{Dims{10, 12, 17}, ValueType::F32, Field::Smooth, 2},
                                   std::tuple{Dims{19, 18, 17}, ValueType::I16, Field::Plateau, 4}}) {
        SCOPED_TRACE(dims_str(d) + " bricks " + std::to_string(bricks));
        const Volume v = make_volume(d, t, f, 5);
        std::vector<uint8_t> first;
        for (int threads : {1, 2, 0}) {  // 0: the TBB default
            MtBuildOptions o;
            o.brick_cells = bricks;
            o.threads = threads;
            const auto bytes = encode_mt(MtModel::build(v, o));
            if (first.empty()) first = bytes;
            EXPECT_TRUE(bytes == first) << threads << " threads";
        }
    }
}

// Streams above large_stream_bytes are compressed at min(zstd_level,
// large_stream_zstd_level); the others at zstd_level. Checked on the bytes: with
// every stream "large" the container is the one of that level everywhere, with
// none it is the one of zstd_level, and a threshold between the streams' sizes
// gives a third container that still decodes to the same model.
TEST(MtCodec, LargeStreamsTakeTheirOwnLevel) {
    const Built b = build({17, 15, 13}, ValueType::U8, Field::Noisy);
    auto encode = [&](int level, int large_level, size_t large_bytes) {
        MtEncodeOptions o;
        o.zstd_level = level;
        o.large_stream_zstd_level = large_level;
        o.large_stream_bytes = large_bytes;
        return encode_mt(b.model, o);
    };
    const auto at19 = encode(19, 0, 0), at1 = encode(1, 0, 0);
    ASSERT_FALSE(at19 == at1);
    EXPECT_TRUE(encode(19, 1, 0) == at1) << "every stream large: level 1 everywhere";
    EXPECT_TRUE(encode(19, 1, SIZE_MAX) == at19) << "no stream large: level 19 everywhere";
    EXPECT_TRUE(encode(1, 19, 0) == at1) << "the large-stream level never raises the level";
    EXPECT_TRUE(encode(19, 19, 0) == at19);
    // The default: 12 above 1 MiB, which no stream of this small model reaches.
    EXPECT_TRUE(encode_mt(b.model) == at19);
    // A threshold between the streams' sizes (the near offsets and the label low
    // bytes have one byte per update; the base tets 16 bytes per tet).
    const size_t updates = b.model.updates().size();
    const auto mixed = encode(19, 1, updates - 1);
    EXPECT_FALSE(mixed == at19);
    EXPECT_FALSE(mixed == at1);
    auto dec = decode_mt(mixed, &b.vol);
    ASSERT_TRUE(dec.ok()) << dec.failure().message;
    MtEncodeOptions again;
    again.large_stream_bytes = SIZE_MAX;
    EXPECT_TRUE(encode_mt(dec.value(), again) == at19) << "the same model";
}

TEST(MtCodec, EveryPrefixFailsCleanly) {
    const Built b = build({5, 4, 6}, ValueType::U8, Field::Smooth);
    const auto bytes = encode_mt(b.model);
    for (size_t len = 0; len < bytes.size(); ++len) {
        auto r = decode_mt(std::span<const uint8_t>(bytes.data(), len), &b.vol);
        EXPECT_FALSE(r.ok()) << "prefix " << len;
    }
    auto extra = bytes;
    extra.push_back(0);
    EXPECT_FALSE(decode_mt(extra, &b.vol).ok());
    auto bad = bytes;
    bad[4] = 9;  // version
    auto r = decode_mt(bad, &b.vol);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.failure().code, ErrorCode::UnsupportedVersion);
    bad = bytes;
    bad[0] = 'X';
    EXPECT_EQ(decode_mt(bad, &b.vol).failure().code, ErrorCode::BadMagic);
    EXPECT_EQ(decode_mt(bytes, nullptr).failure().code, ErrorCode::NotFound);
}

/// What a refusal may say: a decoder failure of untrusted bytes, never an I/O or usage code.
bool is_refusal_code(ErrorCode c) {
    return c == ErrorCode::Truncated || c == ErrorCode::BadMagic || c == ErrorCode::UnsupportedVersion ||
           c == ErrorCode::CorruptData || c == ErrorCode::TooLarge;
}

/// Structural checks of an accepted model's mesh (no error bound: corrupted
/// error codes are data the decoder cannot tell from real ones).
CheckOptions structure_only() {
    CheckOptions o;
    o.allowed = nullptr;
    return o;
}

/// The raw streams of a coding-2 payload (spec/tlod-format.md §10.2): per stream
/// a u64 raw length, a u64 frame length and the zstd frame (none when empty).
std::vector<std::vector<std::byte>> unframe(const std::vector<uint8_t>& bytes) {
    std::vector<std::vector<std::byte>> streams;
    size_t at = 48;
    while (at < bytes.size()) {
        uint64_t len = 0, frame = 0;
        std::memcpy(&len, bytes.data() + at, 8);
        std::memcpy(&frame, bytes.data() + at + 8, 8);
        at += 16;
        std::vector<std::byte> raw;
        if (len != 0) {
            auto r = tlod::zstd_decompress(
                std::span<const std::byte>(reinterpret_cast<const std::byte*>(bytes.data() + at), frame), len);
            EXPECT_TRUE(r.ok());
            if (r.ok()) raw = std::move(r.value());
        }
        streams.push_back(std::move(raw));
        at += frame;
    }
    return streams;
}

/// Header + streams framed again as coding 2, with the header's sizes updated.
std::vector<uint8_t> reframe(const std::vector<uint8_t>& bytes, const std::vector<std::vector<std::byte>>& streams) {
    std::vector<uint8_t> file(bytes.begin(), bytes.begin() + 48);
    uint64_t raw_size = 0;
    for (const auto& st : streams) {
        const std::vector<std::byte> z = st.empty() ? std::vector<std::byte>{} : tlod::zstd_compress(st, 1);
        const uint64_t len = st.size(), zs = z.size();
        raw_size += 8 + len;
        const auto* lb = reinterpret_cast<const uint8_t*>(&len);
        const auto* zb = reinterpret_cast<const uint8_t*>(&zs);
        file.insert(file.end(), lb, lb + 8);
        file.insert(file.end(), zb, zb + 8);
        const auto* fb = reinterpret_cast<const uint8_t*>(z.data());
        file.insert(file.end(), fb, fb + z.size());
    }
    const uint64_t stored = file.size() - 48;
    std::memcpy(file.data() + 32, &raw_size, 8);
    std::memcpy(file.data() + 40, &stored, 8);
    return file;
}

TEST(MtCodec, WritesCodingTwoWithElevenStreams) {
    const Built b = build({6, 5, 7}, ValueType::U8, Field::Noisy);
    MtEncodeOptions o;
    o.coding = 2;
    const auto bytes = encode_mt(b.model, o);
    EXPECT_EQ(bytes[4] | (bytes[5] << 8), 2);
    const auto streams = unframe(bytes);
    ASSERT_EQ(streams.size(), 11u);
    const size_t nu = b.model.updates().size();
    EXPECT_EQ(streams[1].size(), nu);  // one near-offset byte per update
    EXPECT_EQ(streams[4].size(), nu);  // error code high bytes
    EXPECT_EQ(streams[5].size(), nu);  // error code low bytes
    EXPECT_TRUE(streams[10].empty());  // field not included
    EXPECT_TRUE(reframe(bytes, streams) != bytes);  // level 1, not the writer's 19
    ASSERT_TRUE(decode_mt(reframe(bytes, streams), &b.vol).ok());
    o.coding = 4;
    EXPECT_THROW(encode_mt(b.model, o), Error);
}

/// Coding 3 (spec §10.2): 12 streams; labels as a low-byte plane and varints of
/// the rest, in raster order of w; error codes in increasing label order, ties
/// in raster order. Checked against the model directly, not through the decoder.
TEST(MtCodec, WritesCodingThreeWithErrorsInLabelOrder) {
    const Built b = build({33, 31, 29}, ValueType::U16, Field::Smooth);  // labels above 255
    const auto bytes = encode_mt(b.model);
    EXPECT_EQ(bytes[4] | (bytes[5] << 8), 3);
    const auto streams = unframe(bytes);
    ASSERT_EQ(streams.size(), 12u);
    const auto& ups = b.model.updates();
    const size_t nu = ups.size();
    ASSERT_EQ(streams[3].size(), nu);
    ASSERT_EQ(streams[5].size(), nu);
    ASSERT_EQ(streams[6].size(), nu);
    EXPECT_TRUE(streams[11].empty());
    // Updates in raster order of w, as the file lists them.
    std::vector<size_t> raster(nu);
    for (size_t k = 0; k < nu; ++k) raster[k] = k;
    std::sort(raster.begin(), raster.end(), [&](size_t a, size_t c) { return ups[a].w < ups[c].w; });
    size_t at = 0;
    bool some_high = false;
    for (size_t i = 0; i < nu; ++i) {
        const uint32_t label = ups[raster[i]].label;
        ASSERT_EQ(uint8_t(streams[3][i]), uint8_t(label)) << i;
        uint64_t hi = 0;
        for (int shift = 0;; shift += 7) {
            const uint8_t byte = uint8_t(streams[4][at++]);
            hi |= uint64_t(byte & 0x7F) << shift;
            if (!(byte & 0x80)) break;
        }
        ASSERT_EQ(hi, label >> 8) << i;
        some_high = some_high || hi != 0;
    }
    EXPECT_EQ(at, streams[4].size());
    std::vector<size_t> by_label = raster;
    std::stable_sort(by_label.begin(), by_label.end(), [&](size_t a, size_t c) { return ups[a].label < ups[c].label; });
    for (size_t j = 0; j < nu; ++j) {
        const uint16_t code = quantize_error(ups[by_label[j]].error, 7);
        ASSERT_EQ(uint8_t(streams[5][j]), uint8_t(code >> 8)) << j;
        ASSERT_EQ(uint8_t(streams[6][j]), uint8_t(code)) << j;
    }
    // The order matters: the model has distinct labels with distinct errors, so
    // listing the codes in raster order would fail the loop above.
    bool differs = false;
    for (size_t j = 0; j < nu && !differs; ++j)
        differs = quantize_error(ups[by_label[j]].error, 7) != quantize_error(ups[raster[j]].error, 7);
    EXPECT_TRUE(differs);
    EXPECT_TRUE(some_high) << "no label reached the varint stream";
}

/// Flips single bits of the 16-byte header of every stream in the stored
/// payload (its raw and frame lengths): every flip must be refused cleanly.
TEST(MtCodec, HostileStreamFramesAreRefused) {
    const Built b = build({5, 4, 6}, ValueType::U8, Field::Smooth);
    const auto bytes = encode_mt(b.model);
    std::vector<size_t> heads;
    for (size_t at = 48; at < bytes.size();) {
        heads.push_back(at);
        uint64_t frame = 0;
        std::memcpy(&frame, bytes.data() + at + 8, 8);
        at += 16 + frame;
    }
    ASSERT_EQ(heads.size(), 12u);
    int refused = 0;
    for (size_t h : heads)
        for (size_t i = h; i < h + 16; ++i)
            for (int bit = 0; bit < 8; ++bit) {
                auto mut = bytes;
                mut[i] ^= uint8_t(1u << bit);
                auto r = decode_mt(mut, &b.vol);
                ASSERT_FALSE(r.ok()) << "byte " << i << " bit " << bit;
                EXPECT_TRUE(r.failure().code == ErrorCode::Truncated || r.failure().code == ErrorCode::CorruptData ||
                            r.failure().code == ErrorCode::TooLarge)
                    << r.failure().message;
                EXPECT_EQ(r.failure().message.rfind("MT", 0), 0u) << r.failure().message;
                ++refused;
            }
    EXPECT_EQ(refused, 12 * 16 * 8);
}

/// Flips bits of the decompressed streams, re-frames them, and decodes: the decoder
/// must refuse with a decoder error code, or give a model whose extractions either
/// fail with CorruptData or are valid, conforming meshes covering the box.
void hostile_streams_never_crash(int coding) {
    const Built b = build({6, 5, 7}, ValueType::U8, Field::Noisy);
    MtEncodeOptions o;
    o.coding = coding;
    const auto bytes = encode_mt(b.model, o);
    const auto streams = unframe(bytes);
    size_t total = 0;
    for (const auto& st : streams) total += st.size();
    ASSERT_GT(total, 0u);
    std::mt19937 rng(5);
    int decoded = 0, refused = 0, extracted = 0, extraction_refused = 0;
    for (int iter = 0; iter < 400; ++iter) {
        auto mut = streams;
        const int flips = 1 + int(rng() % 3);
        for (int f = 0; f < flips; ++f) {
            size_t at = rng() % total, k = 0;
            while (at >= mut[k].size()) at -= mut[k].size(), ++k;
            mut[k][at] ^= std::byte(uint8_t(1u << (rng() % 8)));
        }
        const std::vector<uint8_t> file = reframe(bytes, mut);
        auto r = decode_mt(file, &b.vol);
        if (!r.ok()) {
            ++refused;
            EXPECT_TRUE(is_refusal_code(r.failure().code)) << r.failure().message;
            EXPECT_EQ(r.failure().message.rfind("MT", 0), 0u) << r.failure().message;
            continue;
        }
        ++decoded;
        for (double e : {-1.0, 0.0, 10.0}) {
            LodQuery q;
            q.error_in = e;
            try {
                const TetMesh m = r.value().extract(q);
                ++extracted;
                EXPECT_TRUE(mesh_ok(b.vol, m, structure_only())) << "iteration " << iter << " error " << e;
            } catch (const Error& err) {
                ++extraction_refused;
                EXPECT_EQ(err.code(), ErrorCode::CorruptData) << err.what();
            }
        }
    }
    std::printf("[ mt ] hostile streams, coding %d: %d refused, %d decoded; %d extractions valid, %d refused\n",
                coding, refused, decoded, extracted, extraction_refused);
    // Both outcomes must occur, or the test checks nothing.
    EXPECT_GE(refused, 100);
    EXPECT_GE(extracted, 10);
}

TEST(MtCodec, HostileStreamsNeverCrash) {
    for (int coding : {3, 2}) {
        SCOPED_TRACE("coding " + std::to_string(coding));
        hostile_streams_never_crash(coding);
    }
}

/// Every single-bit flip of the 48-byte header: only the error mantissa bits
/// (byte 21, values 0..7) are free, and only when every stored code stays in
/// range; every other flip must be refused with a decoder error code. An
/// accepted model must give valid meshes, and exact ones at error 0 (code 0
/// means 0 at every precision).
TEST(MtCodec, HostileHeadersNeverCrash) {
    const Built b = build({4, 4, 4}, ValueType::U8, Field::Smooth);
    MtEncodeOptions o;
    o.error_mantissa_bits = 4;  // flips to 5 and 6 keep every code in range, so some are accepted
    const auto bytes = encode_mt(b.model, o);
    ASSERT_EQ(bytes[21], 4);
    int accepted = 0, refused = 0;
    for (size_t i = 0; i < 48; ++i)
        for (int bit = 0; bit < 8; ++bit) {
            SCOPED_TRACE("byte " + std::to_string(i) + " bit " + std::to_string(bit));
            auto mut = bytes;
            mut[i] ^= uint8_t(1u << bit);
            auto r = decode_mt(mut, &b.vol);
            if (!r.ok()) {
                ++refused;
                EXPECT_TRUE(is_refusal_code(r.failure().code)) << r.failure().message;
                EXPECT_EQ(r.failure().message.rfind("MT", 0), 0u) << r.failure().message;
                continue;
            }
            ++accepted;
            EXPECT_TRUE(i == 21 && bit < 3) << "a corrupt header was accepted";
            LodQuery full;
            full.full = true;
            const TetMesh fm = r.value().extract(full);
            EXPECT_EQ(int64_t(fm.tet_count()), 5 * cells(b.vol.dims));
            EXPECT_TRUE(mesh_ok(b.vol, fm, mt_check_options(full, b.vol)));
            LodQuery exact;
            exact.error_in = 0.0;
            EXPECT_TRUE(mesh_ok(b.vol, r.value().extract(exact), mt_check_options(exact, b.vol)));
        }
    std::printf("[ mt ] header bit flips: %d refused, %d accepted\n", refused, accepted);
    EXPECT_GE(accepted, 2);  // mantissa bits 4 -> 5 and 4 -> 6
    EXPECT_EQ(accepted + refused, 48 * 8);
    EXPECT_GE(refused, 48 * 8 - 3);
}

}  // namespace
}  // namespace tetlod::test
