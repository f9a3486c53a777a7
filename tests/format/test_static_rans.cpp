// The static-table rANS coder (codecs/src/entropy/static_rans.hpp): tables
// normalised and coded, symbols and raw bits round-tripped, and the readers on
// malformed input (truncated, corrupt, hostile tables) failing without reading
// outside their input (the sanitized build runs these too).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "entropy/static_rans.hpp"
#include "tetlod/core/error.hpp"

using namespace tetlod::rans;

namespace {

constexpr int kAlphabet = 17;  // a u8 field's: 0 and 8 bit lengths of either sign

uint32_t sum_of(const Frequencies& f) {
    uint32_t s = 0;
    for (auto v : f) s += v;
    return s;
}

/// Tables of every kind: unused, one symbol, two, a skewed many, a flat all.
std::vector<Frequencies> sample_tables() {
    std::vector<Frequencies> t;
    t.push_back(Frequencies{});  // unused
    Counts one{};
    one[3] = 77;
    t.push_back(normalize(one));
    Counts two{};
    two[0] = 1000, two[15] = 1;
    t.push_back(normalize(two));
    Counts skew{};
    for (int s = 0; s < kAlphabet; ++s) skew[size_t(s)] = uint64_t(1) << (2 * (kAlphabet - 1 - s) % 40);
    t.push_back(normalize(skew));
    Counts flat{};
    for (int k = 0; k < kAlphabet; ++k) flat[size_t(k)] = 5;
    t.push_back(normalize(flat));
    std::mt19937_64 rng(7);
    for (int k = 0; k < 20; ++k) {
        Counts c{};
        for (int k = 0; k < kAlphabet; ++k) c[size_t(k)] = (rng() % 3 == 0) ? 0 : rng() % 100000;
        t.push_back(normalize(c));
    }
    return t;
}

/// Symbols drawn from each context's table (only symbols it holds).
void draw(const std::vector<Frequencies>& tables, std::size_t n, uint64_t seed, std::vector<uint8_t>& ctx,
          std::vector<uint8_t>& sym) {
    std::mt19937_64 rng(seed);
    std::vector<std::size_t> used;
    for (std::size_t c = 0; c < tables.size(); ++c)
        if (sum_of(tables[c]) != 0) used.push_back(c);
    ctx.resize(n), sym.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t c = used[rng() % used.size()];
        uint32_t u = uint32_t(rng() % kProbTotal);
        int s = 0;
        while (u >= tables[c][size_t(s)]) u -= tables[c][size_t(s)], ++s;
        ctx[i] = uint8_t(c), sym[i] = uint8_t(s);
    }
}

}  // namespace

TEST(StaticRans, NormalizeSumsToTheTotalAndKeepsEveryCountedSymbol) {
    Counts many{};  // every symbol once but one: 128 lifted to 1
    many.fill(1);
    many[5] = 1000000;
    const Frequencies fm = normalize(many);
    EXPECT_EQ(std::accumulate(fm.begin(), fm.end(), 0u), kProbTotal);
    EXPECT_TRUE(std::all_of(fm.begin(), fm.end(), [](uint16_t v) { return v >= 1; }));
    for (const Frequencies& f : sample_tables()) {
        const uint32_t s = sum_of(f);
        EXPECT_TRUE(s == 0 || s == kProbTotal) << s;
    }
    Counts extreme{};
    extreme[0] = uint64_t(1) << 62, extreme[1] = 1, extreme[9] = uint64_t(1) << 61;
    const Frequencies f = normalize(extreme);
    EXPECT_EQ(sum_of(f), kProbTotal);
    EXPECT_GE(f[1], 1);
    EXPECT_GE(f[9], 1);
    EXPECT_EQ(f[2], 0);
    EXPECT_EQ(sum_of(normalize(Counts{})), 0u);
}

TEST(StaticRans, TablesRoundTripAndTheirSizeIsExact) {
    const auto tables = sample_tables();
    std::vector<std::byte> bytes{std::byte{0xAB}};  // written after what is there
    write_tables(tables, kAlphabet, bytes);
    EXPECT_EQ(bytes.size() - 1, tables_size(tables, kAlphabet));
    std::vector<Frequencies> back(tables.size());
    const auto taken = read_tables(std::span(bytes).subspan(1), kAlphabet, back);
    ASSERT_TRUE(taken.has_value());
    EXPECT_EQ(*taken, bytes.size() - 1);
    EXPECT_EQ(back, tables);
}

TEST(StaticRans, MalformedTablesAreRefused) {
    const auto tables = sample_tables();
    std::vector<std::byte> bytes;
    write_tables(tables, kAlphabet, bytes);
    std::vector<Frequencies> back(tables.size());
    // Every truncation: refused (the last byte holds bits of the last table).
    for (std::size_t n = 0; n < bytes.size(); ++n)
        EXPECT_FALSE(read_tables(std::span(bytes).first(n), kAlphabet, back).has_value()) << n;
    std::vector<Frequencies> one(1);
    // First symbol after the last, and a last symbol outside the alphabet.
    RawBitWriter swapped;
    swapped.put(1, 1), swapped.put(3, 5), swapped.put(2, 5);
    EXPECT_FALSE(read_tables(swapped.finish(), kAlphabet, one).has_value());
    RawBitWriter outside;
    outside.put(1, 1), outside.put(0, 5), outside.put(17, 5);
    EXPECT_FALSE(read_tables(outside.finish(), kAlphabet, one).has_value());
    // Symbols 0 and 1 (first 0, last 1, nothing between), symbol 0's frequency
    // 2048 leaves nothing for 1: gamma(2048) = 11 zeros, a one, 11 bits.
    RawBitWriter w;
    w.put(1, 1), w.put(0, 5), w.put(1, 5), w.put(0, 11), w.put(1, 1), w.put(0, 11);
    EXPECT_FALSE(read_tables(w.finish(), kAlphabet, one).has_value());
    // The same with 2047: valid, symbol 1 gets 1.
    RawBitWriter ok;
    ok.put(1, 1), ok.put(0, 5), ok.put(1, 5), ok.put(0, 10), ok.put(1, 1), ok.put(2047 & 1023, 10);
    auto fine = ok.finish();
    ASSERT_TRUE(read_tables(fine, kAlphabet, one).has_value());
    EXPECT_EQ(one[0][0], 2047);
    EXPECT_EQ(one[0][1], 1);
    // Padding bits that are not zero (30 bits: frequency 1000 = 9 zeros, a one, 9 bits).
    RawBitWriter padded;
    padded.put(1, 1), padded.put(0, 5), padded.put(1, 5), padded.put(0, 9), padded.put(1, 1), padded.put(1000 & 511, 9);
    auto pad = padded.finish();
    ASSERT_TRUE(read_tables(pad, kAlphabet, one).has_value());
    EXPECT_EQ(one[0][1], 1048);
    pad.back() |= std::byte{0x80};
    EXPECT_FALSE(read_tables(pad, kAlphabet, one).has_value());
    // A gamma code longer than any frequency (12 zeros).
    RawBitWriter longer;
    longer.put(1, 1), longer.put(0, 5), longer.put(1, 5), longer.put(0, 12), longer.put(1, 1), longer.put(0, 12);
    EXPECT_FALSE(read_tables(longer.finish(), kAlphabet, one).has_value());
    // The widest alphabet: 129 symbols, 8-bit first and last fields.
    std::vector<Frequencies> wide(2);
    Counts c{};
    c[0] = 5, c[64] = 7, c[128] = 1;
    wide[1] = normalize(c);
    std::vector<std::byte> wb;
    write_tables(wide, kMaxSymbols, wb);
    std::vector<Frequencies> wback(2);
    ASSERT_TRUE(read_tables(wb, kMaxSymbols, wback).has_value());
    EXPECT_EQ(wback, wide);
    EXPECT_THROW(write_tables(wide, kAlphabet, wb), tetlod::Error);
}

TEST(StaticRans, SymbolsRoundTripOnEveryLength) {
    const auto tables = sample_tables();
    std::vector<uint32_t> slots;
    const DecodeTables dt(tables, slots);
    for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(2), std::size_t(3), std::size_t(1000),
                          std::size_t(200000)}) {
        std::vector<uint8_t> ctx, sym;
        draw(tables, n, n + 1, ctx, sym);
        const auto stream = encode(tables, ctx, sym);
        std::vector<std::byte> storage;
        Decoder d(PaddedStream(stream, storage));
        std::size_t wrong = 0;
        for (std::size_t i = 0; i < n; ++i) {
            wrong += d.next(dt.context(ctx[i])) != sym[i];
            if (i % PaddedStream::kMaxUnchecked == 0) d.check();
        }
        d.check();
        EXPECT_EQ(wrong, 0u) << n;
        EXPECT_TRUE(d.ended_exactly()) << n;
    }
}

TEST(StaticRans, EncoderRefusesASymbolItsTableDoesNotHold) {
    const auto tables = sample_tables();
    const std::vector<uint8_t> ctx{1}, bad{4}, unused_ctx{0}, sym{3};
    EXPECT_THROW(encode(tables, ctx, bad), tetlod::Error);
    EXPECT_THROW(encode(tables, unused_ctx, sym), tetlod::Error);
    EXPECT_NO_THROW(encode(tables, ctx, sym));
}

TEST(StaticRans, TruncatedAndCorruptStreamsNeverEndExactly) {
    const auto tables = sample_tables();
    std::vector<uint32_t> slots;
    const DecodeTables dt(tables, slots);
    std::vector<uint8_t> ctx, sym;
    draw(tables, 5000, 99, ctx, sym);
    const auto stream = encode(tables, ctx, sym);
    std::vector<std::byte> storage;
    auto run = [&](std::span<const std::byte> s) {
        Decoder d(PaddedStream(s, storage));
        for (std::size_t i = 0; i < ctx.size(); ++i) {
            d.next(dt.context(ctx[i]));
            if (i % PaddedStream::kMaxUnchecked == 0) d.check();
        }
        d.check();
        return d.ended_exactly();
    };
    ASSERT_TRUE(run(stream));
    for (std::size_t n = 0; n < stream.size(); n += 1 + n / 16) EXPECT_FALSE(run(std::span(stream).first(n))) << n;
    // Random bytes of every small size and some large ones: no crash, no read
    // outside (the sanitized build checks), and never a clean end by chance here.
    std::mt19937_64 rng(3);
    for (std::size_t n : {0, 1, 7, 8, 9, 64, 4096}) {
        std::vector<std::byte> junk(n);
        for (auto& b : junk) b = std::byte(rng());
        EXPECT_FALSE(run(junk)) << n;
    }
    // A context without a table decodes to kMaxSymbols.
    Decoder d(PaddedStream(stream, storage));
    EXPECT_EQ(d.next(dt.context(0)), kMaxSymbols);
}

TEST(StaticRans, RawBitsRoundTripAndDetectTheirEnd) {
    std::mt19937_64 rng(11);
    std::vector<std::pair<uint64_t, int>> items;
    RawBitWriter w;
    for (int k = 0; k < 5000; ++k) {
        const int bits = int(rng() % 57);
        const uint64_t v = bits == 0 ? 0 : rng() & (~uint64_t{0} >> (64 - bits));
        items.push_back({v, bits});
        w.put(v, bits);
    }
    const auto bytes = w.finish();
    std::vector<std::byte> storage;
    RawBitReader r(PaddedStream(bytes, storage));
    std::size_t wrong = 0;
    for (const auto& [v, bits] : items) {
        r.refill();
        wrong += r.take(bits) != v;  // bits <= 56: one take after a refill
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_TRUE(r.ended_exactly());
    r.refill();
    r.take(9);
    EXPECT_TRUE(r.overrun());
    // Short streams: a valid 1-byte stream does not overrun on its refill.
    RawBitWriter small;
    small.put(5, 3);
    const auto one = small.finish();
    std::vector<std::byte> storage1;
    RawBitReader rs(PaddedStream(one, storage1));
    rs.refill();
    EXPECT_EQ(rs.take(3), 5u);
    EXPECT_TRUE(rs.ended_exactly());
    EXPECT_FALSE(rs.overrun());
    // Non-zero padding is not an exact end.
    auto padded = one;
    padded[0] |= std::byte{0x80};
    std::vector<std::byte> storage2;
    RawBitReader rp(PaddedStream(padded, storage2));
    rp.refill();
    rp.take(3);
    EXPECT_FALSE(rp.ended_exactly());
}
