#pragma once
// Chunk mode 6, static (format 3.7, spec §7.6 "Static tables"): a field
// chunk's residuals, in the points, order and prediction of range mode, as one
// symbol per point (its bit length with the sign folded in) from frequency
// tables the chunk carries, through the static-table rANS coder
// (entropy/static_rans.hpp); the bits below the leading one raw beside.
//
// Why: decoding speed (issue 13). Range mode decodes a point with several
// adaptive binary decisions (12-45 ns a point); here a symbol is a table load
// and a multiply. The context leaves out the row's previous point, so the
// decoder works out a whole block's contexts before decoding it and the
// chains of successive points (two interleaved rANS states) overlap. It costs
// bytes: the tables, and statistics that do not adapt within a chunk.
#include <algorithm>
#include <array>
#include <optional>
#include <string>

#include "../entropy/static_rans.hpp"
#include "ht_field_chunk_coder.hpp"
#include "tetlod/core/varint.hpp"

namespace tetlod::ht_detail {

constexpr int kStaticContexts = 64;  // 16 buckets per class (spec §7.6)
constexpr int kStaticInlineLength = 7;  // bit lengths 1..7 in the symbol
constexpr int kStaticEscape = rans::kSymbols - 1;  // longer: 6 raw bits of length, 1 of sign
/// The smallest section (spec §6.4): 64 used bits and one used table (16
/// presence bits) make 10 bytes, then a 1-byte length and the two states.
constexpr uint64_t kMinStaticBytes = 19;

/// A point's table: its class and the §7.6 bucket of spread + 2 nbr', nbr'
/// the neighbours' mean without the row's previous point.
[[gnu::always_inline]] inline int static_context(int cls, uint64_t spread, uint64_t nbr) {
    return 16 * cls + activity_bucket(spread + 2 * nbr);
}

/// 0 for 0; n (1..7) for a positive residual of bit length n, 7 + n for a
/// negative one; kStaticEscape for bit lengths of 8 and more. The sign is in
/// the symbol: the floor of the prediction's mean makes one sign the likelier.
[[gnu::always_inline]] inline int static_symbol(uint64_t mag, bool neg) {
    const int n = rc::bit_length(mag);
    return n == 0 ? 0 : n <= kStaticInlineLength ? (neg ? kStaticInlineLength + n : n) : kStaticEscape;
}

/// A point's raw bits: for an escape, its bit length − 8 (6 bits) and its
/// sign (1 bit); then the bits of the magnitude below its leading one.
inline void put_static_raw(rans::RawBitWriter& w, uint64_t mag, bool neg) {
    const int n = rc::bit_length(mag);
    if (n > kStaticInlineLength) w.put(uint64_t(n - kStaticInlineLength - 1), 6), w.put(neg ? 1 : 0, 1);
    if (n > 1) {
        const uint64_t rest = mag & (~uint64_t{0} >> (65 - n));
        if (n - 1 > 48) w.put(rest & 0xFFFFFF, 24), w.put(rest >> 24, n - 1 - 24);
        else w.put(rest, n - 1);
    }
}

/// The encoder's step: records each point's context and symbol, writes its raw bits.
template <class T>
struct FieldPointStaticRecorder {
    std::vector<uint8_t>* contexts = nullptr;
    std::vector<uint8_t>* symbols = nullptr;
    std::array<rans::Counts, kStaticContexts>* counts = nullptr;
    rans::RawBitWriter* raw = nullptr;
    const T* v = nullptr;
    LatticeView lat;

    void operator()(int cls, const Prediction& pr, int64_t idx, int64_t s) {
        using D = Dom<T>;
        const int ctx = static_context(cls, pr.spread, lat.neighbour_mean_without_prev(s));
        const auto r = typename D::S(typename D::U(uint64_t(D::get(v[idx])) - uint64_t(pr.p)));
        const bool neg = r < 0;
        const uint64_t mag = neg ? uint64_t(0) - uint64_t(int64_t(r)) : uint64_t(r);
        const int sym = static_symbol(mag, neg);
        contexts->push_back(uint8_t(ctx));
        symbols->push_back(uint8_t(sym));
        ++(*counts)[size_t(ctx)][size_t(sym)];
        put_static_raw(*raw, mag, neg);
        lat.set(s, mag);
    }
};

/// A mode-6 section's content (spec §7.6): the tables, the rANS stream's
/// length as a varint, the stream, the raw bits; and whether every residual
/// was 0 (then zero-residual mode codes the chunk in no bytes).
struct StaticChunk {
    std::vector<std::byte> bytes;
    bool zero_residuals = false;
};
template <class T>
StaticChunk encode_static_chunk(const Geometry& G, const T* v, const HtChunk& c) {
    std::vector<uint8_t> contexts, symbols;
    contexts.reserve(std::size_t(c.points)), symbols.reserve(std::size_t(c.points));
    std::array<rans::Counts, kStaticContexts> counts{};
    rans::RawBitWriter raw;
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    FieldPointStaticRecorder<T> step{&contexts, &symbols, &counts, &raw, v, lat.view()};
    walk_field_chunk(G, v, c, lat, step);
    std::array<rans::Frequencies, kStaticContexts> tables;
    for (int k = 0; k < kStaticContexts; ++k) tables[size_t(k)] = rans::normalize(counts[size_t(k)]);
    StaticChunk out;
    out.zero_residuals = std::all_of(counts.begin(), counts.end(), [](const rans::Counts& k) {
        return std::all_of(k.begin() + 1, k.end(), [](uint64_t n) { return n == 0; });
    });
    rans::write_tables(tables, out.bytes);
    const auto stream = rans::encode(tables, contexts, symbols);
    put_varint(out.bytes, stream.size());
    out.bytes.insert(out.bytes.end(), stream.begin(), stream.end());
    const auto bits = raw.finish();
    out.bytes.insert(out.bytes.end(), bits.begin(), bits.end());
    return out;
}

/// What a mode-6 decoder keeps across the points of a chunk (a value type: a
/// row's loop keeps a copy in locals). The raw bits are refilled once every
/// kRefillEvery points: an inline symbol takes at most 6 of them, and a
/// refill leaves at least 56; an escape refills around its own.
struct StaticPointReader {
    static constexpr int kRefillEvery = 8;
    rans::Decoder dec;
    rans::RawBitReader raw;
    bool bad = false;  // a symbol of an unused table, or a bit length above W

    /// The magnitude and sign of the next point, whose table is `slots`.
    template <int W>
    [[gnu::always_inline]] uint64_t next(const uint32_t* slots, bool& neg) {
        // Per symbol: the magnitude's leading one and how many raw bits follow
        // it (the escape's, and the unused tables' kSymbols, fixed below).
        static constexpr uint8_t kLead[rans::kSymbols + 1] = {0, 1, 2, 4, 8, 16, 32, 64, 1, 2, 4, 8, 16, 32, 64, 0, 0};
        static constexpr uint8_t kBits[rans::kSymbols + 1] = {0, 0, 1, 2, 3, 4, 5, 6, 0, 1, 2, 3, 4, 5, 6, 0, 0};
        const int sym = dec.next(slots);
        neg = sym > kStaticInlineLength;
        if (sym >= kStaticEscape) [[unlikely]]
            return escape<W>(sym, neg);
        return uint64_t(kLead[sym]) | raw.take(kBits[sym]);
    }

    template <int W>
    [[gnu::noinline]] uint64_t escape(int sym, bool& neg) {
        bad = bad || sym > kStaticEscape;
        raw.refill();
        int n = kStaticInlineLength + 1 + int(raw.take(6));
        neg = raw.take(1) != 0;
        raw.refill();
        if (n > W) bad = true, n = W;
        uint64_t mag;
        if (n - 1 > 48) {
            const uint64_t lo = raw.take(24);
            raw.refill();
            mag = (uint64_t{1} << (n - 1)) | lo | (raw.take(n - 1 - 24) << 24);
        } else {
            mag = (uint64_t{1} << (n - 1)) | raw.take(n - 1);
        }
        raw.refill();
        return mag;
    }
};

/// Decodes a mode-6 section into the chunk's points. Returns an empty string
/// or what is wrong with it.
template <class T>
std::string decode_static_chunk(const Geometry& G, T* v, const HtChunk& c, std::span<const std::byte> in) {
    using D = Dom<T>;
    using U = typename D::U;
    if (c.points == 0) return in.empty() ? "" : "bytes in an empty chunk";
    std::array<rans::Frequencies, kStaticContexts> tables;
    const auto taken = rans::read_tables(in, tables);
    if (!taken) return "malformed static tables";
    // The rANS stream's length: a varint of at most 5 bytes in shortest form.
    std::size_t at = *taken;
    uint64_t len = 0;
    for (int shift = 0;; shift += 7) {
        if (at >= in.size() || shift > 28) return "malformed static stream length";
        const uint8_t b = uint8_t(in[at++]);
        len |= uint64_t(b & 0x7F) << shift;
        if (!(b & 0x80)) {
            if (b == 0 && shift > 0) return "malformed static stream length";
            break;
        }
    }
    if (len < 8 || len > in.size() - at) return "static stream length outside the section";
    thread_local std::vector<uint32_t> slot_storage;
    thread_local std::vector<std::byte> stream_storage, raw_storage;
    const rans::DecodeTables dt(tables, slot_storage);
    const rans::PaddedStream stream(in.subspan(at, std::size_t(len)), stream_storage);
    const rans::PaddedStream bits(in.subspan(at + std::size_t(len)), raw_storage);
    StaticPointReader rd{rans::Decoder(stream), rans::RawBitReader(bits)};

    thread_local std::vector<uint32_t> lattice_storage;
    ChunkLattice lat(c.cycle, c.box, lattice_storage);
    const LatticeView lv = lat.view();
    const ChunkFrame Fr(G, c.cycle, c.box);
    const int t = c.cycle;
    for_each_row_v2(G, t, c.box, [&](const ChunkRow& row) {
        dispatch_row_class(row, [&]<int Cls>(const ChunkRow& r) {
            int64_t idx = G.index(r.x0, r.y, r.z);
            int64_t s = lat.slot(r.x0, r.y, r.z);
            const int64_t didx = G.index_delta(r.step, 0, 0), ds = r.step >> t;
            StaticPointReader local = rd;  // in registers across the row
            T* const vv = v;
            // Locals: a decoded value's store (a byte may alias anything reached
            // through a pointer) would make the loop reload them at every point.
            const uint32_t* const base = dt.base();
            uint8_t block[kStaticContexts];
            for (int k = 0; k < kStaticContexts; ++k) block[k] = dt.block(size_t(k));
            auto slots = [&](int ctx) __attribute__((always_inline)) {
                return base + std::size_t(block[ctx]) * rans::kProbTotal;
            };
            if constexpr (Cls == 3) {
                for (int64_t x = r.x0; x <= r.x1; x += r.step, idx += didx, s += ds) {
                    local.raw.refill();
                    local.dec.check();
                    bool neg;
                    const uint64_t mag =
                        local.next<D::W>(slots(static_context(3, 0, lv.neighbour_mean_without_prev(s))), neg);
                    vv[idx] = D::put(neg ? U(uint64_t(0) - mag) : U(mag));
                    lv.set(s, mag);
                }
            } else {
                const RowPredictor<T, Cls> P(G, Fr, r);
                const RowEvenStrides even = row_even_strides(r, lv);
                int64_t pp[kDecodeBlock];
                uint64_t psp[kDecodeBlock], osum[kDecodeBlock];
                uint32_t on[kDecodeBlock];
                const int64_t x1 = r.x1, xs = r.step;
                for (int64_t x = r.x0; x <= x1;) {
                    const int64_t n = std::min<int64_t>(kDecodeBlock, (x1 - x) / xs + 1);
                    predict_block<T, Cls>(G, Fr, t, r, P, lv, even, vv, x, n, idx, s, didx, ds, pp, psp, osum, on);
                    local.dec.check();
                    for (int64_t i = 0; i < n; ++i, idx += didx, s += ds) {
                        if (i % StaticPointReader::kRefillEvery == 0) local.raw.refill();
                        const int ctx = static_context(Cls, psp[i], LatticeView::mean_of(osum[i], on[i]));
                        bool neg;
                        const uint64_t mag = local.next<D::W>(slots(ctx), neg);
                        const U rr = neg ? U(uint64_t(0) - mag) : U(mag);
                        vv[idx] = D::put(U(uint64_t(pp[i]) + uint64_t(rr)));
                        lv.set(s, mag);
                    }
                    x += n * xs;
                }
            }
            rd = local;
        });
    });
    rd.dec.check();
    if (rd.bad) return "a symbol of an unused table, or a residual longer than the type";
    if (!rd.dec.ended_exactly()) return "malformed static rANS stream";
    if (!rd.raw.ended_exactly()) return "malformed static raw bits";
    return "";
}

}  // namespace tetlod::ht_detail
