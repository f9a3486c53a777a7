// MT serialization: round trips (decoded models pass the checker, re-encoding is
// byte-identical), determinism, and hostile bytes (every prefix, flipped bytes in
// the header and in the decompressed streams) failing cleanly.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "mt_test_util.hpp"
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
        for (bool with_field : {false, true}) {
            MtEncodeOptions o;
            o.include_field = with_field;
            const auto bytes = encode_mt(b.model, o);
            auto dec = decode_mt(bytes, with_field ? nullptr : &b.vol);
            ASSERT_TRUE(dec.ok()) << dec.failure().message;
            const MtModel& m = dec.value();
            EXPECT_EQ(m.updates().size(), b.model.updates().size());
            EXPECT_TRUE(m.base_tets() == b.model.base_tets());
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

/// Flips bytes of the decompressed payload, re-frames it, and decodes: the decoder
/// must refuse with a decoder error code, or give a model whose extractions either
/// fail with CorruptData or are valid, conforming meshes covering the box.
TEST(MtCodec, HostileStreamsNeverCrash) {
    const Built b = build({6, 5, 7}, ValueType::U8, Field::Noisy);
    const auto bytes = encode_mt(b.model);
    uint64_t raw_size = 0, stored = 0;
    std::memcpy(&raw_size, bytes.data() + 32, 8);
    std::memcpy(&stored, bytes.data() + 40, 8);
    auto raw = tlod::zstd_decompress(
        std::span<const std::byte>(reinterpret_cast<const std::byte*>(bytes.data() + 48), stored), raw_size);
    ASSERT_TRUE(raw.ok());
    std::mt19937 rng(5);
    int decoded = 0, refused = 0, extracted = 0, extraction_refused = 0;
    for (int iter = 0; iter < 400; ++iter) {
        std::vector<std::byte> mut = raw.value();
        const int flips = 1 + int(rng() % 3);
        for (int f = 0; f < flips; ++f) mut[rng() % mut.size()] ^= std::byte(uint8_t(1u << (rng() % 8)));
        const auto z = tlod::zstd_compress(mut, 1);
        std::vector<uint8_t> file(bytes.begin(), bytes.begin() + 48);
        const uint64_t rs = mut.size(), zs = z.size();
        std::memcpy(file.data() + 32, &rs, 8);
        std::memcpy(file.data() + 40, &zs, 8);
        const auto* zb = reinterpret_cast<const uint8_t*>(z.data());
        file.insert(file.end(), zb, zb + z.size());
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
    std::printf("[ mt ] hostile streams: %d refused, %d decoded; %d extractions valid, %d refused\n", refused,
                decoded, extracted, extraction_refused);
    // Both outcomes must occur, or the test checks nothing.
    EXPECT_GE(refused, 100);
    EXPECT_GE(extracted, 10);
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
