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
/// The symbols of a type of W bits: 0, then bit lengths 1..W of positive
/// residuals, then of negative ones.
constexpr int static_alphabet(int w_bits) { return 2 * w_bits + 1; }
/// The smallest section (spec §6.4): 64 used bits and one used table (first
/// and last symbol, 5 bits each at least) make 10 bytes, then a 1-byte length
/// and the two states.
constexpr uint64_t kMinStaticBytes = 19;

/// A point's table: its class and the §7.6 bucket of spread + 2 nbr', nbr'
/// the neighbours' mean without the row's previous point.
[[gnu::always_inline]] inline int static_context(int cls, uint64_t spread, uint64_t nbr) {
    return 16 * cls + activity_bucket(spread + 2 * nbr);
}

/// 0 for 0; n for a positive residual of bit length n, W + n for a negative
/// one (W the type's bits). The sign is in the symbol: the floor of the
/// prediction's mean makes one sign the likelier; so is the bit length of every
/// type (an escape to raw length bits cost wide types 15-50 % more bytes).
template <int W>
[[gnu::always_inline]] inline int static_symbol(uint64_t mag, bool neg) {
    const int n = rc::bit_length(mag);
    return n == 0 ? 0 : neg ? W + n : n;
}

/// A point's raw bits: those of its magnitude below the leading one.
inline void put_static_raw(rans::RawBitWriter& w, uint64_t mag) {
    const int n = rc::bit_length(mag);
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
        const int sym = static_symbol<D::W>(mag, neg);
        contexts->push_back(uint8_t(ctx));
        symbols->push_back(uint8_t(sym));
        ++(*counts)[size_t(ctx)][size_t(sym)];
        put_static_raw(*raw, mag);
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
    rans::write_tables(tables, static_alphabet(Dom<T>::W), out.bytes);
    const auto stream = rans::encode(tables, contexts, symbols);
    put_varint(out.bytes, stream.size());
    out.bytes.insert(out.bytes.end(), stream.begin(), stream.end());
    const auto bits = raw.finish();
    out.bytes.insert(out.bytes.end(), bits.begin(), bits.end());
    return out;
}

/// What a mode-6 decoder keeps across the points of a chunk (a value type: a
/// row's loop keeps a copy in locals). The raw bits are refilled once every
/// refill_every<W>() points: a point takes at most W - 1 of them, and a refill
/// leaves at least 56 (64-bit types refill within a point as well).
struct StaticPointReader {
    rans::Decoder dec;
    rans::RawBitReader raw;
    bool bad = false;  // a symbol outside the type's alphabet, or of an unused table

    template <int W>
    static constexpr int refill_every() { return W - 1 <= 56 ? 56 / (W - 1) : 1; }

    /// Per symbol of a W-bit type (and one more, for every symbol outside
    /// the alphabet): the magnitude's leading one, and the raw bits below it.
    template <int W>
    struct Symbols {
        std::array<uint64_t, 2 * W + 2> lead{};
        std::array<uint8_t, 2 * W + 2> bits{};
        constexpr Symbols() {
            for (int s = 1; s <= 2 * W; ++s) {
                const int n = s > W ? s - W : s;
                lead[size_t(s)] = uint64_t{1} << (n - 1);
                bits[size_t(s)] = uint8_t(n - 1);
            }
        }
    };

    /// The magnitude and sign of the next point, whose table is `slots`.
    template <int W>
    [[gnu::always_inline]] uint64_t next(const uint32_t* slots, bool& neg) {
        static constexpr Symbols<W> kSym{};
        const int sym = dec.next(slots);
        bad = bad || sym > 2 * W;
        const int k = sym > 2 * W ? 2 * W + 1 : sym;
        neg = k > W;
        const int bits = kSym.bits[size_t(k)];
        if constexpr (W - 1 > 56) {
            if (bits > 48) {  // more than one take holds
                const uint64_t lo = raw.take(24);
                raw.refill();
                return kSym.lead[size_t(k)] | lo | (raw.take(bits - 24) << 24);
            }
        }
        return kSym.lead[size_t(k)] | raw.take(bits);
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
    const auto taken = rans::read_tables(in, static_alphabet(D::W), tables);
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
                        if (i % StaticPointReader::refill_every<D::W>() == 0) local.raw.refill();
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
    if (rd.bad) return "a symbol of an unused table, or outside the type's alphabet";
    if (!rd.dec.ended_exactly()) return "malformed static rANS stream";
    if (!rd.raw.ended_exactly()) return "malformed static raw bits";
    return "";
}

}  // namespace tetlod::ht_detail
