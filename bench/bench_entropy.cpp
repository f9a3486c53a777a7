// The entropy stage of the HT field decoder alone, on the residuals and
// contexts of real volumes, against a candidate for a faster format (issue 13:
// decode >= 200 MB/s). Not a format: an experiment that settles which coder
// design is worth a format bump, with the numbers in docs/archival.md.
//
// Each chunk of a volume is walked as the range-coded mode does (spec §7.4,
// §7.6): per point its class, the prediction's spread and the neighbours'
// magnitude sum and count other than the row's previous point, its residual.
// Those are then coded and decoded three ways, the decode timed with the
// context of each point depending on the magnitude just decoded, as in the
// real decoder:
//   binary     today's coder: adaptive binary decisions (zero flag, sign,
//              unary bit length, two context-coded mantissa bits, the rest
//              direct), ht_codec_entropy.hpp;
//   binary-x2  the same, two chunks decoded in lockstep on one thread (two
//              independent coder chains: does instruction-level parallelism
//              help?);
//   symbols    a prototype: the bit length as one symbol of an adaptive
//              16-entry distribution per context (one range-coder step per
//              point, no data-dependent branch), sign and mantissa bits as raw
//              bits in a second stream read 64 bits at a time.
//   duo        symbols, with one symbol for two small residuals of a row;
//   tab        static tables and rANS: the symbols of sym-np from fixed
//              frequency tables (per chunk, or per cycle shared by its
//              chunks), two interleaved states, raw bits read without a
//              branch; decoded from a context byte per point, so it times the
//              entropy stage alone (the other coders read 40-byte records);
//   bin-2d     today's binary coder with the spread's and the neighbours'
//              mean's buckets as two context dimensions (size only).
// Usage: bench_entropy [DATA_DIR] [--reps N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <string>
#include <vector>

#include <emmintrin.h>

#include "../codecs/src/ht/ht_field_chunk_coder.hpp"
#include "tetlod/tetlod.hpp"

using namespace tetlod;
using namespace tetlod::ht_detail;

namespace {

/// What the decoder of one point needs besides the stream.
struct PointRecord {
    uint64_t spread = 0, others_sum = 0;
    uint32_t others_n = 0;
    uint8_t cls = 0;
    bool row_start = false;   // the row's previous point is unset (wprev 0)
    bool full_mean = false;   // class 3: the bucket is given whole (no previous point)
    uint8_t given_bucket = 0; // class 3 only
    uint64_t mag = 0;
    bool neg = false;
};

/// Walks a chunk as the range coder's encoder does and records every point.
template <class T>
struct Recorder {
    std::vector<PointRecord>* out = nullptr;
    const T* v = nullptr;
    LatticeView lat;
    RowEvenStrides even;
    bool first = true;
    void begin_row(const ChunkRow& r) {
        if (r.cls < 3) even = row_even_strides(r, lat);
        first = true;
    }
    void operator()(int cls, const Prediction& pr, int64_t idx, int64_t s) {
        using D = Dom<T>;
        PointRecord p;
        p.cls = uint8_t(cls);
        p.spread = pr.spread;
        if (cls < 3) {
            const auto o = lat.others_in_order(cls, s, even.even1, even.even2);
            p.others_sum = o.sum;
            p.others_n = o.n;
            p.row_start = first && lat.mag[s - 2] == 0;
        } else {
            p.full_mean = true;
            p.given_bucket = uint8_t(activity_bucket(pr.spread + 2 * lat.neighbour_mean(s)));
        }
        const auto r = typename D::S(typename D::U(uint64_t(D::get(v[idx])) - uint64_t(pr.p)));
        p.neg = r < 0;
        p.mag = p.neg ? uint64_t(0) - uint64_t(int64_t(r)) : uint64_t(r);
        lat.set(s, p.mag);
        first = false;
        out->push_back(p);
    }
};

[[gnu::always_inline]] inline int bucket_of(const PointRecord& p, uint32_t wprev) {
    if (p.full_mean) return p.given_bucket;
    return activity_bucket(p.spread + 2 * LatticeView::mean_with_prev(LatticeView::Others{p.others_sum, p.others_n}, wprev));
}

// ---- today's binary coder ----

std::vector<std::byte> encode_binary(const std::vector<PointRecord>& pts, int w) {
    std::vector<std::byte> out;
    rc::Encoder e(out);
    auto m = std::make_unique<FieldModels>();
    uint32_t wprev = 0;
    for (const auto& p : pts) {
        if (p.row_start) wprev = 0;
        rc::encode_int(e, m->m[p.cls][bucket_of(p, wprev)], p.mag, p.neg, w);
        wprev = LatticeView::stored(p.mag);
    }
    e.finish();
    return out;
}

/// A two-dimensional context: the prediction spread's bucket and the
/// neighbours' mean's bucket apart, each capped at 7 (8 x 8 per class), where
/// today's coder takes one bucket of spread + 2 mean. Caps of 5, 9 and 11 were
/// tried: 7 is as good as any within 0.5 % on every volume but headsq (-1.6 % at 9).
constexpr int kCap2d = 7;
[[gnu::always_inline]] inline int context_2d(const PointRecord& p, uint32_t wprev) {
    if (p.full_mean) return p.given_bucket;  // class 3: a bucket given whole, as in 1d
    const int sb = std::min(kCap2d, activity_bucket(p.spread));
    const int mb = std::min(
        kCap2d, activity_bucket(2 * LatticeView::mean_with_prev(LatticeView::Others{p.others_sum, p.others_n}, wprev)));
    return (kCap2d + 1) * sb + mb;
}

/// Today's binary coder with a two-dimensional context: the spread's bucket and
/// the neighbours' mean's bucket apart (8 x 8 per class) instead of one bucket
/// of their sum (size only: does the sum lose what the static tables found?).
std::vector<std::byte> encode_binary_2d(const std::vector<PointRecord>& pts, int w) {
    std::vector<std::byte> out;
    rc::Encoder e(out);
    struct Models {
        rc::IntModel m[4][64];
    };
    auto m = std::make_unique<Models>();
    uint32_t wprev = 0;
    for (const auto& p : pts) {
        if (p.row_start) wprev = 0;
        const int c = context_2d(p, wprev);
        rc::encode_int(e, m->m[p.cls][c], p.mag, p.neg, w);
        wprev = LatticeView::stored(p.mag);
    }
    e.finish();
    return out;
}

uint64_t decode_binary(const std::vector<PointRecord>& pts, const std::vector<std::byte>& in, int w) {
    rc::Decoder d(in.data(), in.size());
    auto m = std::make_unique<FieldModels>();
    uint32_t wprev = 0;
    uint64_t check = 0;
    for (const auto& p : pts) {
        if (p.row_start) wprev = 0;
        uint64_t mag;
        bool neg;
        rc::decode_int(d, m->m[p.cls][bucket_of(p, wprev)], mag, neg, w);
        check += mag + neg;
        wprev = LatticeView::stored(mag);
    }
    return check;
}

/// Two chunks in lockstep (the shorter one's tail alone).
uint64_t decode_binary_pair(const std::vector<PointRecord>& a, const std::vector<std::byte>& ia,
                            const std::vector<PointRecord>& b, const std::vector<std::byte>& ib, int w) {
    rc::Decoder da(ia.data(), ia.size()), db(ib.data(), ib.size());
    auto ma = std::make_unique<FieldModels>(), mb = std::make_unique<FieldModels>();
    uint32_t wa = 0, wb = 0;
    uint64_t check = 0;
    const std::size_t n = std::min(a.size(), b.size());
    for (std::size_t i = 0; i < n; ++i) {
        const PointRecord &pa = a[i], &pb = b[i];
        if (pa.row_start) wa = 0;
        if (pb.row_start) wb = 0;
        uint64_t m1, m2;
        bool n1, n2;
        rc::decode_int(da, ma->m[pa.cls][bucket_of(pa, wa)], m1, n1, w);
        rc::decode_int(db, mb->m[pb.cls][bucket_of(pb, wb)], m2, n2, w);
        check += m1 + n1 + m2 + n2;
        wa = LatticeView::stored(m1);
        wb = LatticeView::stored(m2);
    }
    auto tail = [&](const std::vector<PointRecord>& pts, rc::Decoder& d, FieldModels& m, uint32_t wprev) {
        for (std::size_t i = n; i < pts.size(); ++i) {
            const PointRecord& p = pts[i];
            if (p.row_start) wprev = 0;
            uint64_t mag;
            bool neg;
            rc::decode_int(d, m.m[p.cls][bucket_of(p, wprev)], mag, neg, w);
            check += mag + neg;
            wprev = LatticeView::stored(mag);
        }
    };
    tail(a, da, *ma, wa);
    tail(b, db, *mb, wb);
    return check;
}

// ---- prototype: one adaptive symbol per point, raw bits beside ----

constexpr int kSymbols = 16;    // bit lengths 0..14, 15 = escape (length 15.. in 6 raw bits)
constexpr int kProbBits = 15;   // cumulative frequencies in 1/32768

/// An adaptive distribution over `kSymbols` symbols: c[k] = P(symbol < k) in
/// 1/32768, c[0] = 0, P(symbol < kSymbols) = 1 implied; c[k] stays within
/// [k, 32768 - (kSymbols - k)], so no symbol's probability reaches 0 and every
/// entry fits a signed 16-bit lane (two SSE2 registers hold the model).
struct alignas(32) SymbolModel {
    int16_t c[kSymbols];
    uint16_t count = 0;
    SymbolModel() {
        for (int k = 0; k < kSymbols; ++k) c[k] = int16_t((k << kProbBits) / kSymbols);
    }
    [[gnu::always_inline]] void update(int s) {
        // Fast at first (a chunk's contexts start from a uniform guess), then
        // settling, as the binary coder's shift 1 .. 6.
        const int rate = count < 1 ? 1 : count < 3 ? 2 : count < 7 ? 3 : count < 15 ? 4 : count < 31 ? 5 : 6;
        count = uint16_t(count + (count < 31));
        // Entries above the symbol move towards their ceiling, the others
        // towards their floor (entry 0 stays 0: its floor and value are 0).
        const __m128i idx_lo = _mm_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7);
        const __m128i idx_hi = _mm_setr_epi16(8, 9, 10, 11, 12, 13, 14, 15);
        // The ceiling of entry k: 32768 - (kSymbols - k) (at most 32767).
        const __m128i ceil_lo = _mm_add_epi16(_mm_set1_epi16(32768 - kSymbols), idx_lo);
        const __m128i ceil_hi = _mm_add_epi16(_mm_set1_epi16(32768 - kSymbols), idx_hi);
        const __m128i sv = _mm_set1_epi16(int16_t(s));
        const __m128i sh = _mm_cvtsi32_si128(rate);
        auto step = [&](__m128i c, __m128i idx, __m128i ceil) {
            const __m128i above = _mm_cmpgt_epi16(idx, sv);
            const __m128i up = _mm_add_epi16(c, _mm_sra_epi16(_mm_sub_epi16(ceil, c), sh));
            const __m128i down = _mm_sub_epi16(c, _mm_sra_epi16(_mm_sub_epi16(c, idx), sh));
            return _mm_or_si128(_mm_and_si128(above, up), _mm_andnot_si128(above, down));
        };
        __m128i* p = reinterpret_cast<__m128i*>(c);
        _mm_store_si128(p, step(_mm_load_si128(p), idx_lo, ceil_lo));
        _mm_store_si128(p + 1, step(_mm_load_si128(p + 1), idx_hi, ceil_hi));
    }
    /// The number of k in 1..kSymbols-1 whose bound 2 r c[k] is at most
    /// `code` (r < 2^16, so r c[k] < 2^31: signed 32-bit lanes compare it
    /// with code / 2, which is the same test).
    [[gnu::always_inline]] int count_bounds_at_most(uint32_t r, uint32_t code) const {
        const __m128i rv = _mm_set1_epi16(int16_t(uint16_t(r)));
        const __m128i half = _mm_set1_epi32(int32_t(code >> 1));
        const __m128i* p = reinterpret_cast<const __m128i*>(c);
        auto gt = [&](__m128i cv) {  // 8 lanes of r c[k] > code / 2, as 16-bit masks
            const __m128i lo = _mm_mullo_epi16(cv, rv), hi = _mm_mulhi_epu16(cv, rv);
            const __m128i a = _mm_cmpgt_epi32(_mm_unpacklo_epi16(lo, hi), half);
            const __m128i b = _mm_cmpgt_epi32(_mm_unpackhi_epi16(lo, hi), half);
            return _mm_packs_epi32(a, b);
        };
        const int m = _mm_movemask_epi8(_mm_packs_epi16(gt(_mm_load_si128(p)), gt(_mm_load_si128(p + 1))));
        // The bounds increase with k: the lanes above the code are the top ones,
        // from the symbol + 1 on (a count without popcnt, which x86-64's
        // baseline lacks: GCC called a library function for it).
        return __builtin_ctz(uint32_t(m) | (1u << kSymbols)) - 1;
    }
};

struct SymbolEncoder {
    std::vector<std::byte>* out;
    uint64_t low = 0;
    uint32_t range = 0xFFFFFFFFu;
    uint8_t cache = 0;
    uint64_t pending = 1;
    void encode(SymbolModel& m, int s) {
        const uint32_t r = range >> 16;
        const uint32_t lo = 2 * r * uint32_t(m.c[s]);
        const uint32_t hi = s == kSymbols - 1 ? range : 2 * r * uint32_t(m.c[s + 1]);
        low += lo;
        range = hi - lo;
        m.update(s);
        while (range < (1u << 24)) {
            range <<= 8;
            shift_low();
        }
    }
    void shift_low() {
        if (uint32_t(low) < 0xFF000000u || (low >> 32) != 0) {
            const uint8_t carry = uint8_t(low >> 32);
            uint8_t temp = cache;
            do {
                out->push_back(std::byte(uint8_t(temp + carry)));
                temp = 0xFF;
            } while (--pending != 0);
            cache = uint8_t(low >> 24);
        }
        ++pending;
        low = (low & 0x00FFFFFFu) << 8;
    }
    void finish() {
        for (int i = 0; i < 5; ++i) shift_low();
    }
};

struct SymbolDecoder {
    const std::byte *p, *end;
    uint32_t code = 0, range = 0xFFFFFFFFu;
    SymbolDecoder(const std::byte* d, std::size_t n) : p(d), end(d + n) {
        next();
        for (int i = 0; i < 4; ++i) code = (code << 8) | next();
    }
    [[gnu::always_inline]] uint32_t next() { return p == end ? 0 : uint32_t(std::to_integer<uint8_t>(*p++)); }
    [[gnu::always_inline]] int decode(SymbolModel& m) {
        // The symbol is the number of k >= 1 whose lower bound is at most the
        // code: no branch on the data. Bounds 2 r c[k] with r = range / 2^16
        // (the binary coder's precision).
        const uint32_t r = range >> 16;
        const int s = m.count_bounds_at_most(r, code);
        const uint32_t lo = 2 * r * uint32_t(m.c[s]);
        const uint32_t hi = s == kSymbols - 1 ? range : 2 * r * uint32_t(m.c[s + 1]);
        code -= lo;
        range = hi - lo;
        m.update(s);
        while (range < (1u << 24)) {
            range <<= 8;
            code = (code << 8) | next();
        }
        return s;
    }
};

struct BitWriter {
    std::vector<std::byte> out;
    uint64_t acc = 0;
    int n = 0;
    void put(uint64_t v, int bits) {  // bits <= 57
        acc |= v << n;
        n += bits;
        while (n >= 8) {
            out.push_back(std::byte(uint8_t(acc)));
            acc >>= 8;
            n -= 8;
        }
    }
    void finish() {
        if (n > 0) out.push_back(std::byte(uint8_t(acc)));
        for (int i = 0; i < 8; ++i) out.push_back(std::byte{0});  // the reader's look-ahead
    }
};

struct BitReader {
    const std::byte *p, *end;
    uint64_t acc = 0;
    int n = 0;
    [[gnu::always_inline]] uint64_t get(int bits) {  // 0 <= bits <= 56
        if (n < bits) [[unlikely]] {
            uint64_t w = 0;
            if (end - p >= 8) std::memcpy(&w, p, 8);
            const int take = (63 - n) >> 3;
            acc |= w << n;
            p += take;
            n += take * 8;
        }
        const uint64_t v = acc & ((uint64_t{1} << bits) - 1);
        acc >>= bits;
        n -= bits;
        return v;
    }
};

struct SymbolStreams {
    std::vector<std::byte> symbols, bits;
    std::size_t size() const { return symbols.size() + bits.size() - 8; }  // the look-ahead padding is not data
};

struct SymbolModels {
    SymbolModel m[4][16];
};

/// The symbol of a residual: 0 for 0, n (1..7) for a positive one of bit
/// length n, 7 + n for a negative one, 15 (escape) for bit lengths 8 and more
/// (then n - 8 and the sign in raw bits). The sign is in the symbol because the
/// floor of the mean makes one sign the likelier (the binary coder's sign
/// context captures it too).
constexpr int kMaxInlineLength = 7;

/// One point's symbol (model given by its context, `wprev` the previous
/// point's lattice value or 0) and its raw bits.
void encode_one(SymbolEncoder& e, BitWriter& bw, SymbolModels& m, const PointRecord& p, uint32_t wprev) {
    const int n = rc::bit_length(p.mag);
    const int sym = n == 0 ? 0 : n <= kMaxInlineLength ? (p.neg ? kMaxInlineLength + n : n) : kSymbols - 1;
    e.encode(m.m[p.cls][bucket_of(p, wprev)], sym);
    if (sym == kSymbols - 1) {
        bw.put(uint64_t(n - kMaxInlineLength - 1), 6);
        bw.put(p.neg, 1);
    }
    if (n > 1) {
        const uint64_t rest = p.mag & ((uint64_t{1} << (n - 1)) - 1);
        if (n - 1 > 48) {
            bw.put(rest & 0xFFFFFF, 24);
            bw.put(rest >> 24, n - 1 - 24);
        } else {
            bw.put(rest, n - 1);
        }
    }
}

template <bool UsePrev>
SymbolStreams encode_symbols(const std::vector<PointRecord>& pts) {
    SymbolStreams out;
    SymbolEncoder e{&out.symbols};
    BitWriter bw;
    auto m = std::make_unique<SymbolModels>();
    uint32_t wprev = 0;
    for (const auto& p : pts) {
        if (p.row_start) wprev = 0;
        encode_one(e, bw, *m, p, UsePrev ? wprev : 0);
        wprev = LatticeView::stored(p.mag);
    }
    e.finish();
    bw.finish();
    out.bits = std::move(bw.out);
    return out;
}

/// One chunk's symbol decoder state: the two streams, the models and the
/// previous point's lattice value.
struct SymbolChunkDecoder {
    SymbolDecoder d;
    BitReader br;
    std::unique_ptr<SymbolModels> m = std::make_unique<SymbolModels>();
    uint32_t wprev = 0;
    explicit SymbolChunkDecoder(const SymbolStreams& in)
        : d(in.symbols.data(), in.symbols.size()), br{in.bits.data(), in.bits.data() + in.bits.size()} {}

    template <bool UsePrev>
    [[gnu::always_inline]] uint64_t point(const PointRecord& p) {
        if (p.row_start) wprev = 0;
        const int sym = d.decode(m->m[p.cls][bucket_of(p, UsePrev ? wprev : 0)]);
        int n = sym > kMaxInlineLength ? sym - kMaxInlineLength : sym;
        bool neg = sym > kMaxInlineLength;
        if (sym == kSymbols - 1) [[unlikely]] {
            n = kMaxInlineLength + 1 + int(br.get(6));
            neg = br.get(1) != 0;
        }
        // No branch on the symbol: bit lengths 0 and 1 read no raw bits.
        uint64_t rest;
        if (n > 49) [[unlikely]] rest = br.get(24) | (br.get(n - 1 - 24) << 24);
        else rest = br.get(std::max(n - 1, 0));
        const uint64_t mag = n > 0 ? (uint64_t{1} << (n - 1)) | rest : 0;
        if constexpr (UsePrev) wprev = LatticeView::stored(mag);
        return mag + neg;
    }
};

template <bool UsePrev>
uint64_t decode_symbols(const std::vector<PointRecord>& pts, const SymbolStreams& in) {
    SymbolChunkDecoder c(in);
    uint64_t check = 0;
    for (const auto& p : pts) check += c.point<UsePrev>(p);
    return check;
}

template <bool UsePrev>
uint64_t decode_symbols_pair(const std::vector<PointRecord>& a, const SymbolStreams& ia,
                             const std::vector<PointRecord>& b, const SymbolStreams& ib) {
    SymbolChunkDecoder ca(ia), cb(ib);
    uint64_t check = 0;
    const std::size_t n = std::min(a.size(), b.size());
    for (std::size_t i = 0; i < n; ++i) check += ca.point<UsePrev>(a[i]) + cb.point<UsePrev>(b[i]);
    for (std::size_t i = n; i < a.size(); ++i) check += ca.point<UsePrev>(a[i]);
    for (std::size_t i = n; i < b.size(); ++i) check += cb.point<UsePrev>(b[i]);
    return check;
}

// ---- prototype: one symbol for two small residuals ----
//
// Two successive points of a row whose residuals are both -1, 0 or +1 take one
// symbol (3 a + b, 0..8) of a model chosen by the first point's context
// (without the previous point, as sym-np); 9 escapes to one symbol each, as
// sym-np codes them. A row's odd last point is coded alone.

[[gnu::always_inline]] inline int trit(const PointRecord& p) { return p.mag == 0 ? 1 : p.neg ? 0 : 2; }

constexpr int kDuoEscape = 9;

SymbolStreams encode_duos(const std::vector<PointRecord>& pts) {
    SymbolStreams out;
    SymbolEncoder e{&out.symbols};
    BitWriter bw;
    auto single = std::make_unique<SymbolModels>(), duo = std::make_unique<SymbolModels>();
    for (std::size_t i = 0; i < pts.size();) {
        const PointRecord& p = pts[i];
        if (i + 1 < pts.size() && !pts[i + 1].row_start) {
            const PointRecord& q = pts[i + 1];
            const bool small = p.mag <= 1 && q.mag <= 1;
            e.encode(duo->m[p.cls][bucket_of(p, 0)], small ? 3 * trit(p) + trit(q) : kDuoEscape);
            if (!small) encode_one(e, bw, *single, p, 0), encode_one(e, bw, *single, q, 0);
            i += 2;
        } else {
            encode_one(e, bw, *single, p, 0);
            i += 1;
        }
    }
    e.finish();
    bw.finish();
    out.bits = std::move(bw.out);
    return out;
}

uint64_t decode_duos(const std::vector<PointRecord>& pts, const SymbolStreams& in) {
    SymbolChunkDecoder c(in);  // its models: the single ones
    auto duo = std::make_unique<SymbolModels>();
    uint64_t check = 0;
    for (std::size_t i = 0; i < pts.size();) {
        const PointRecord& p = pts[i];
        if (i + 1 < pts.size() && !pts[i + 1].row_start) {
            const int sym = c.d.decode(duo->m[p.cls][bucket_of(p, 0)]);
            if (sym < kDuoEscape) [[likely]] {
                const int a = sym / 3, b = sym - 3 * (sym / 3);
                check += uint64_t(a != 1) + uint64_t(a == 0) + uint64_t(b != 1) + uint64_t(b == 0);
            } else {
                check += c.point<false>(p) + c.point<false>(pts[i + 1]);
            }
            i += 2;
        } else {
            check += c.point<false>(p);
            i += 1;
        }
    }
    return check;
}

// ---- prototype: static tables, rANS (no adaptation) ----
//
// The symbols of sym-np (bit length with the sign folded in, escape beyond 7),
// but from fixed frequency tables, one per context (class, activity bucket),
// read by a table-driven rANS decoder: per point a mask, one load, a multiply,
// and a 16-bit refill without a branch. Two states alternate point by point, so
// successive points' chains overlap (the contexts do not use the previous point).
// Tables come from the chunk itself ("tab", their cost counted in the chunk) or
// from all chunks of its cycle ("tab-cyc", their cost counted once per cycle: a
// section a query reads beside the chunks, as it reads the header).

constexpr int kTabBits = 11;  // probabilities in 1/2048
constexpr uint32_t kTabTotal = 1u << kTabBits;
constexpr uint32_t kRansLow = 1u << 16;  // state in [2^16, 2^32); refills of 16 bits
constexpr int kContexts = 256;

struct StaticTables {
    // Per context: symbol frequencies (sum kTabTotal when the context is used) and
    // starts; the decoder's slot table gives (symbol, freq, slot - start) per slot.
    std::vector<std::array<uint16_t, kSymbols>> freq, start;
    // Per slot: freq | (slot - start) << 12 | symbol << 23, so a context's 2048
    // slots take 8 KB and the hot ones stay in the first cache levels.
    std::vector<uint32_t> slots;  // kContexts * kTabTotal
    std::vector<uint8_t> used;
    std::size_t cost_bytes = 0;  // an estimate of the tables' serialized size
};

/// A point's static context, without the row's previous point: class and
/// today's bucket (1d, 64 contexts) or class and context_2d (256 contexts).
template <bool TwoD>
inline int context_of(const PointRecord& p) {
    return TwoD ? 64 * p.cls + context_2d(p, 0) : p.cls * 16 + bucket_of(p, 0);
}

inline int symbol_of(const PointRecord& p) {
    const int n = rc::bit_length(p.mag);
    return n == 0 ? 0 : n <= kMaxInlineLength ? (p.neg ? kMaxInlineLength + n : n) : kSymbols - 1;
}

template <bool TwoD>
StaticTables make_tables(const std::vector<const std::vector<PointRecord>*>& chunks) {
    std::vector<std::array<uint64_t, kSymbols>> count(kContexts);
    for (auto& c : count) c.fill(0);
    for (const auto* pts : chunks)
        for (const auto& p : *pts) ++count[size_t(context_of<TwoD>(p))][size_t(symbol_of(p))];
    StaticTables t;
    t.freq.assign(kContexts, {});
    t.start.assign(kContexts, {});
    t.used.assign(kContexts, 0);
    t.slots.resize(size_t(kContexts) * kTabTotal);
    const int contexts = TwoD ? kContexts : 64;
    std::size_t bits = std::size_t(contexts);  // a used flag per context
    for (int c = 0; c < contexts; ++c) {
        uint64_t total = 0;
        for (auto n : count[size_t(c)]) total += n;
        if (total == 0) continue;
        t.used[size_t(c)] = 1;
        auto& f = t.freq[size_t(c)];
        int64_t sum = 0, biggest = 0;
        for (int s = 0; s < kSymbols; ++s) {
            const uint64_t n = count[size_t(c)][size_t(s)];
            f[size_t(s)] = n == 0 ? 0 : uint16_t(std::max<uint64_t>(1, (n * kTabTotal + total / 2) / total));
            sum += f[size_t(s)];
            if (f[size_t(s)] > f[size_t(biggest)]) biggest = s;
        }
        // Fix the sum on the most frequent symbol (it can absorb it: the others are >= 1).
        f[size_t(biggest)] = uint16_t(int64_t(f[size_t(biggest)]) + int64_t(kTabTotal) - sum);
        uint16_t at = 0;
        for (int s = 0; s < kSymbols; ++s) {
            t.start[size_t(c)][size_t(s)] = at;
            for (uint32_t k = 0; k < f[size_t(s)]; ++k)
                t.slots[size_t(c) * kTabTotal + at + k] = uint32_t(f[size_t(s)]) | k << 12 | uint32_t(s) << 23;
            at = uint16_t(at + f[size_t(s)]);
            // Serialized: a presence bit per symbol, then the frequency as an
            // Elias-gamma code (the last present symbol's is implied).
            bits += 1;
            if (f[size_t(s)] > 0) bits += 2 * size_t(rc::bit_length(f[size_t(s)])) - 1;
        }
    }
    t.cost_bytes = (bits + 7) / 8;
    return t;
}

/// Bytes: the rANS stream (written backwards, read forwards) and the raw bits.
template <bool TwoD>
SymbolStreams encode_static(const std::vector<PointRecord>& pts, const StaticTables& t) {
    // Raw bits go forwards in point order; the symbols are coded in reverse.
    BitWriter bw;
    for (const auto& p : pts) {
        const int n = rc::bit_length(p.mag);
        if (n > kMaxInlineLength) bw.put(uint64_t(n - kMaxInlineLength - 1), 6), bw.put(p.neg, 1);
        if (n > 1) {
            const uint64_t rest = p.mag & ((uint64_t{1} << (n - 1)) - 1);
            if (n - 1 > 48) bw.put(rest & 0xFFFFFF, 24), bw.put(rest >> 24, n - 1 - 24);
            else bw.put(rest, n - 1);
        }
    }
    bw.finish();
    std::vector<uint16_t> words;  // in reverse order of reading
    uint32_t x[2] = {kRansLow, kRansLow};
    for (std::size_t i = pts.size(); i-- > 0;) {
        const PointRecord& p = pts[i];
        const int c = context_of<TwoD>(p), s = symbol_of(p);
        const uint32_t f = t.freq[size_t(c)][size_t(s)], st = t.start[size_t(c)][size_t(s)];
        uint32_t& xi = x[i & 1];
        const uint64_t x_max = (uint64_t(kRansLow >> kTabBits) << 16) * f;
        if (xi >= x_max) words.push_back(uint16_t(xi)), xi >>= 16;
        xi = ((xi / f) << kTabBits) + (xi % f) + st;
    }
    // The decoder starts with state 0 then 1: push 1 first (it is read last of the two).
    for (int k = 1; k >= 0; --k) words.push_back(uint16_t(x[k] >> 16)), words.push_back(uint16_t(x[k]));
    SymbolStreams out;
    out.symbols.resize(2 * words.size() + 2);  // +2: the refill's look-ahead
    std::size_t o = 0;
    for (std::size_t i = words.size(); i-- > 0;) {
        std::memcpy(out.symbols.data() + o, &words[i], 2);
        o += 2;
    }
    out.symbols.resize(o);
    out.symbols.push_back(std::byte{0}), out.symbols.push_back(std::byte{0});
    out.bits = std::move(bw.out);
    return out;
}

/// Raw bits, refilled on every read without a branch (at least 56 bits valid
/// after a refill), so a point's raw bits cost no misprediction.
struct BranchlessBits {
    const std::byte *p, *end;
    uint64_t acc = 0;
    int n = 0;
    [[gnu::always_inline]] void refill() {
        uint64_t w = 0;
        if (end - p >= 8) [[likely]] std::memcpy(&w, p, 8);
        acc |= w << n;
        p += (63 - n) >> 3;
        n |= 56;
    }
    [[gnu::always_inline]] uint64_t take(int bits) {  // bits <= n
        const uint64_t v = acc & ((uint64_t{1} << bits) - 1);
        acc >>= bits;
        n -= bits;
        return v;
    }
};

template <int K>
[[gnu::always_inline]] inline uint64_t static_point(uint8_t ctx, uint32_t& xi, const std::byte*& p,
                                                     const uint32_t* slots, BranchlessBits& br) {
    const uint32_t e = slots[size_t(ctx) * kTabTotal + (xi & (kTabTotal - 1))];
    xi = (e & 0xFFF) * (xi >> kTabBits) + ((e >> 12) & 0x7FF);
    // Refill without a branch: the word is always loaded, kept when needed.
    const uint32_t need = xi < kRansLow ? 1u : 0u;
    uint16_t w;
    std::memcpy(&w, p, 2);
    xi = (xi << (16 * need)) | (uint32_t(w) & (0u - need));
    p += 2 * need;
    const int sym = int(e >> 23);
    int n = sym > kMaxInlineLength ? sym - kMaxInlineLength : sym;
    bool neg = sym > kMaxInlineLength;
    br.refill();
    if (sym == kSymbols - 1) [[unlikely]] {
        n = kMaxInlineLength + 1 + int(br.take(6));
        neg = br.take(1) != 0;
        br.refill();
        if (n > 49) {
            const uint64_t lo = br.take(24);
            br.refill();
            return ((uint64_t{1} << (n - 1)) | lo | (br.take(n - 1 - 24) << 24)) + neg;
        }
    }
    const uint64_t rest = br.take(std::max(n - 1, 0));
    const uint64_t mag = n > 0 ? (uint64_t{1} << (n - 1)) | rest : 0;
    return mag + neg;
}

/// `ctx`: each point's context, precomputed (1 byte a point: the bench then
/// times the entropy stage, not the streaming of 40-byte point records, which
/// bounded the large volumes by memory bandwidth).
uint64_t decode_static(const std::vector<uint8_t>& pts, const SymbolStreams& in, const StaticTables& t) {
    const std::byte* p = in.symbols.data();
    auto word32 = [&] {
        uint16_t lo, hi;
        std::memcpy(&lo, p, 2);
        std::memcpy(&hi, p + 2, 2);
        p += 4;
        return uint32_t(lo) | uint32_t(hi) << 16;
    };
    uint32_t x0 = word32(), x1 = word32();
    BranchlessBits br{in.bits.data(), in.bits.data() + in.bits.size()};
    const uint32_t* slots = t.slots.data();
    uint64_t check = 0;
    std::size_t i = 0;
    for (; i + 1 < pts.size(); i += 2) {
        check += static_point<0>(pts[i], x0, p, slots, br);
        check += static_point<1>(pts[i + 1], x1, p, slots, br);
    }
    if (i < pts.size()) check += static_point<0>(pts[i], x0, p, slots, br);
    return check;
}

template <class F>
double best_seconds(int reps, F&& f) {
    double best = 1e30;
    for (int r = 0; r < reps; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return best;
}

struct Row {
    std::string name;
    uint64_t points = 0, binary_bytes = 0, symbol_bytes = 0, noprev_bytes = 0, duo_bytes = 0;
    uint64_t tab_bytes = 0, tabcyc_bytes = 0, tab2d_bytes = 0, bin2d_bytes = 0;
    uint64_t bin_best_bytes = 0;  // per chunk the smaller of binary and bin-2d  // static tables: the chunk's own, the cycle's
    uint64_t zeros = 0, in_zero_blocks = 0;  // zero residuals; points in all-zero blocks of 8 of a row
    double binary_s = 0, pair_s = 0, symbol_s = 0, symbol_pair_s = 0, noprev_s = 0, noprev_pair_s = 0, duo_s = 0;
    double tab_s = 0, tabcyc_s = 0, tab2d_s = 0;
    bool same = true;
};

struct StaticResult {
    uint64_t bytes = 0, check = 0;
    double seconds = 0;
};

/// The static-table coder with 1d or 2d contexts, its tables from each chunk
/// (their cost in the chunk) or from all chunks of a cycle (their cost once
/// per cycle). Decoded from each point's precomputed context byte.
template <bool TwoD>
StaticResult measure_static(const std::vector<std::vector<PointRecord>>& chunks, const std::vector<int>& cycle_of,
                            bool per_cycle, int reps) {
    StaticResult r;
    std::vector<StaticTables> tables(chunks.size());
    std::vector<const StaticTables*> table_of(chunks.size());
    std::vector<StaticTables> of_cycle(64);
    if (per_cycle) {
        for (int cyc = 0; cyc < 64; ++cyc) {
            std::vector<const std::vector<PointRecord>*> of;
            for (std::size_t i = 0; i < chunks.size(); ++i)
                if (cycle_of[i] == cyc) of.push_back(&chunks[i]), table_of[i] = &of_cycle[size_t(cyc)];
            if (of.empty()) continue;
            of_cycle[size_t(cyc)] = make_tables<TwoD>(of);
            r.bytes += of_cycle[size_t(cyc)].cost_bytes;
        }
    } else {
        for (std::size_t i = 0; i < chunks.size(); ++i) {
            tables[i] = make_tables<TwoD>({&chunks[i]});
            table_of[i] = &tables[i];
            r.bytes += tables[i].cost_bytes;
        }
    }
    std::vector<SymbolStreams> streams;
    std::vector<std::vector<uint8_t>> ctx(chunks.size());
    for (std::size_t i = 0; i < chunks.size(); ++i) {
        streams.push_back(encode_static<TwoD>(chunks[i], *table_of[i]));
        r.bytes += streams.back().size() - 2;  // -2: the refill's look-ahead is not data
        for (const auto& p : chunks[i]) ctx[i].push_back(uint8_t(context_of<TwoD>(p)));
    }
    r.seconds = best_seconds(reps, [&] {
        r.check = 0;
        for (std::size_t i = 0; i < chunks.size(); ++i) r.check += decode_static(ctx[i], streams[i], *table_of[i]);
    });
    return r;
}

template <class T>
Row measure(const std::string& name, const Volume& vol, int reps) {
    const HtModel model = HtModel::build(vol);
    const Geometry G = geometry_of(model.domain(), 4);
    const T* v = model.field().as<T>();
    std::vector<std::vector<PointRecord>> chunks;
    std::vector<int> cycle_of;
    for (const HtChunk& c : chunk_list(G)) {
        if (c.points == 0) continue;
        cycle_of.push_back(c.cycle);
        std::vector<PointRecord> pts;
        pts.reserve(c.points);
        thread_local std::vector<uint32_t> storage;
        ChunkLattice lat(c.cycle, c.box, storage);
        Recorder<T> rec{&pts, v, lat.view(), {}, true};
        walk_field_chunk(G, v, c, lat, rec);
        chunks.push_back(std::move(pts));
    }
    constexpr int w = Dom<T>::W;
    Row row;
    row.name = name;
    std::vector<std::vector<std::byte>> bin;
    std::vector<SymbolStreams> sym, sym0, duo;
    for (const auto& pts : chunks) {
        row.points += pts.size();
        bin.push_back(encode_binary(pts, w));
        const std::size_t b2 = encode_binary_2d(pts, w).size();
        row.bin2d_bytes += b2;
        row.bin_best_bytes += std::min(b2, bin.back().size());
        sym.push_back(encode_symbols<true>(pts));
        sym0.push_back(encode_symbols<false>(pts));
        row.binary_bytes += bin.back().size();
        row.symbol_bytes += sym.back().size();
        row.noprev_bytes += sym0.back().size();
        duo.push_back(encode_duos(pts));
        row.duo_bytes += duo.back().size();
    }
    uint64_t c1 = 0, c2 = 0, c3 = 0;
    row.binary_s = best_seconds(reps, [&] {
        c1 = 0;
        for (std::size_t i = 0; i < chunks.size(); ++i) c1 += decode_binary(chunks[i], bin[i], w);
    });
    row.pair_s = best_seconds(reps, [&] {
        c2 = 0;
        std::size_t i = 0;
        for (; i + 1 < chunks.size(); i += 2) c2 += decode_binary_pair(chunks[i], bin[i], chunks[i + 1], bin[i + 1], w);
        if (i < chunks.size()) c2 += decode_binary(chunks[i], bin[i], w);
    });
    row.symbol_s = best_seconds(reps, [&] {
        c3 = 0;
        for (std::size_t i = 0; i < chunks.size(); ++i) c3 += decode_symbols<true>(chunks[i], sym[i]);
    });
    uint64_t c4 = 0, c5 = 0, c6 = 0;
    auto pairs = [&](const std::vector<SymbolStreams>& st, auto use_prev) {
        constexpr bool P = decltype(use_prev)::value;
        uint64_t c = 0;
        std::size_t i = 0;
        for (; i + 1 < chunks.size(); i += 2) c += decode_symbols_pair<P>(chunks[i], st[i], chunks[i + 1], st[i + 1]);
        if (i < chunks.size()) c += decode_symbols<P>(chunks[i], st[i]);
        return c;
    };
    row.symbol_pair_s = best_seconds(reps, [&] { c4 = pairs(sym, std::true_type{}); });
    row.noprev_s = best_seconds(reps, [&] {
        c5 = 0;
        for (std::size_t i = 0; i < chunks.size(); ++i) c5 += decode_symbols<false>(chunks[i], sym0[i]);
    });
    row.noprev_pair_s = best_seconds(reps, [&] { c6 = pairs(sym0, std::false_type{}); });
    uint64_t c7 = 0;
    row.duo_s = best_seconds(reps, [&] {
        c7 = 0;
        for (std::size_t i = 0; i < chunks.size(); ++i) c7 += decode_duos(chunks[i], duo[i]);
    });
    uint64_t expect = 0;
    for (const auto& pts : chunks)
        for (const auto& p : pts) expect += p.mag + p.neg;
    for (const auto& pts : chunks) {
        std::size_t i = 0;
        while (i < pts.size()) {  // rows: from a row start to the next
            std::size_t e = i + 1;
            while (e < pts.size() && !pts[e].row_start) ++e;
            for (std::size_t b = i; b < e; b += 8) {
                const std::size_t n = std::min<std::size_t>(8, e - b);
                bool all = true;
                for (std::size_t k = b; k < b + n; ++k) all = all && pts[k].mag == 0, row.zeros += pts[k].mag == 0;
                if (all && n == 8) row.in_zero_blocks += 8;
            }
            i = e;
        }
    }
    const StaticResult tab = measure_static<false>(chunks, cycle_of, false, reps);
    const StaticResult tabcyc = measure_static<false>(chunks, cycle_of, true, reps);
    const StaticResult tab2d = measure_static<true>(chunks, cycle_of, true, reps);
    row.tab_bytes = tab.bytes, row.tabcyc_bytes = tabcyc.bytes, row.tab2d_bytes = tab2d.bytes;
    row.tab_s = tab.seconds, row.tabcyc_s = tabcyc.seconds, row.tab2d_s = tab2d.seconds;
    row.same = c1 == expect && c2 == expect && c3 == expect && c4 == expect && c5 == expect && c6 == expect &&
               c7 == expect && tab.check == expect && tabcyc.check == expect && tab2d.check == expect;
    return row;
}

}  // namespace

int main(int argc, char** argv) {
    std::string dir = TETLOD_DEFAULT_DATA_DIR;
    int reps = 5;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--reps" && i + 1 < argc) reps = std::atoi(argv[++i]);
        else dir = a;
    }
    std::vector<std::pair<std::string, Volume>> vols;
    if (std::filesystem::is_directory(dir)) {
        std::vector<std::string> files;
        for (const auto& e : std::filesystem::directory_iterator(dir))
            if (e.path().extension() == ".raw") files.push_back(e.path().string());
        std::sort(files.begin(), files.end());
        for (const auto& f : files) vols.emplace_back(std::filesystem::path(f).stem().string(), read_volume(f));
    } else {
        std::printf("(no data folder %s: generated volumes only)\n", dir.c_str());
    }
    vols.emplace_back("gen:multiscale_129^3_u8", make_sample_volume("multiscale", Dims{129, 129, 129}, ValueType::U8));
    vols.emplace_back("gen:noisy_129^3_u8", make_sample_volume("noisy", Dims{129, 129, 129}, ValueType::U8));
    std::printf("HT field entropy stage alone: bytes and one-thread decode ns per point (best of %d)\n", reps);
    std::printf("%-34s %9s %9s %7s %7s %7s | %7s %7s %7s %7s %7s %7s %7s %5s | %6s %6s\n", "volume", "points",
                "binary_B", "sym", "sym-np", "duo", "binary", "bin-x2", "sym", "sym-x2", "sym-np", "np-x2", "duo", "check",
                "zero%", "z8%");
    std::vector<Row> rows;
    for (const auto& [name, vol] : vols) {
        Row r;
        dispatch_value_type(vol.type, [&](auto tv) { r = measure<decltype(tv)>(name, vol, reps); });
        rows.push_back(r);
        const double n = double(r.points) / 1e9;
        std::printf("%-34s %9llu %9llu %6.3fx %6.3fx %6.3fx | %7.2f %7.2f %7.2f %7.2f %7.2f %7.2f %7.2f %5s | %6.1f %6.1f\n",
                    r.name.c_str(),
                    (unsigned long long)r.points, (unsigned long long)r.binary_bytes,
                    double(r.symbol_bytes) / double(r.binary_bytes), double(r.noprev_bytes) / double(r.binary_bytes),
                    double(r.duo_bytes) / double(r.binary_bytes), r.binary_s / n, r.pair_s / n, r.symbol_s / n,
                    r.symbol_pair_s / n, r.noprev_s / n, r.noprev_pair_s / n, r.duo_s / n, r.same ? "ok" : "BAD", 100.0 * double(r.zeros) / double(r.points),
                    100.0 * double(r.in_zero_blocks) / double(r.points));
    }
    std::printf("sizes relative to binary; times in ns per point, one thread (x2: two chunks in lockstep;\n"
                "np: contexts without the row's previous point, so a point's model does not wait for it;\n"
                "duo: sym-np with one symbol for two successive points of a row whose residuals are -1, 0 or +1);\n"
                "zero%%: points with a zero residual; z8%%: points in blocks of 8 along a row whose residuals are all zero\n");
    std::printf("\nStatic tables and rANS, decoded from a context byte per point (tab: 1d contexts, tables from\n"
                "the chunk, their cost in it; tab-cyc: 1d, tables from all chunks of the cycle, their cost once\n"
                "per cycle; tab-2d: as tab-cyc with 2d contexts); bin-2d: today's adaptive binary coder with 2d\n"
                "contexts (size only), best: per chunk the smaller of binary and bin-2d; sizes relative to binary, ns per point, one thread\n");
    std::printf("%-34s %9s %7s %7s %7s %7s %7s %7s | %7s %7s %7s %7s %7s\n", "volume", "binary_B", "bin-2d", "best", "duo", "tab",
                "tab-cyc", "tab-2d", "binary", "duo", "tab", "tab-cyc", "tab-2d");
    for (const Row& r : rows) {
        const double n = double(r.points) / 1e9, b = double(r.binary_bytes);
        std::printf("%-34s %9llu %6.3fx %6.3fx %6.3fx %6.3fx %6.3fx %6.3fx | %7.2f %7.2f %7.2f %7.2f %7.2f\n", r.name.c_str(),
                    (unsigned long long)r.binary_bytes, double(r.bin2d_bytes) / b, double(r.bin_best_bytes) / b, double(r.duo_bytes) / b,
                    double(r.tab_bytes) / b, double(r.tabcyc_bytes) / b, double(r.tab2d_bytes) / b, r.binary_s / n,
                    r.duo_s / n, r.tab_s / n, r.tabcyc_s / n, r.tab2d_s / n);
    }
    return 0;
}
