#pragma once
// Adaptive binary range coder of the .tlod format 2 (spec/tlod-format.md §7.4).
//
// A carry-propagating range coder over 32-bit ranges in the style of
// G. N. N. Martin, "Range encoding: an algorithm for removing redundancy from a
// digitised message" (1979), with binary adaptive probabilities as popularised
// by LZMA; written from the spec's pseudocode. Probabilities are 16-bit with a
// per-context adaptation rate that starts fast (shift 1) and settles at shift
// 6, so short sections (one brick of one cycle) learn quickly.
//
// The decoder is safe on untrusted input: reads past the end yield zero bytes
// and set `overrun()`, which callers turn into CorruptData.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace tetlod::rc {

/// One adaptive binary context: p = P(bit = 0) in 1/65536, n = updates so far (capped).
struct Bit {
    uint16_t p = 32768;
    uint8_t n = 0;
    // Both moves computed and one selected: the bit is data, and a branch on
    // it is mispredicted about as often as the bit is surprising.
    [[gnu::always_inline]] void update(int bit) {
        const int shift = n < 5 ? n + 1 : 6;
        n = uint8_t(n + (n < 5));
        const uint32_t down = uint32_t(p) - (uint32_t(p) >> shift);
        const uint32_t up = uint32_t(p) + ((65536u - p) >> shift);
        p = uint16_t(bit ? down : up);
    }
};

class Encoder {
public:
    // A pointer, not a reference, so the coders can keep a copy of the
    // encoder in locals per row (as the decoder) and assign it back.
    explicit Encoder(std::vector<std::byte>& out) : out_(&out) {}
    // Inlined into the coders' loops and without a branch on the bit, as the
    // decoder; the byte output (once per 8 coded bits at most) stays a call.
    [[gnu::always_inline]] void encode(Bit& b, int bit) {
        const uint32_t bound = (range_ >> 16) * b.p;
        low_ += bit ? bound : 0;
        range_ = bit ? range_ - bound : bound;
        b.update(bit);
        normalize();
    }
    /// A bit of probability exactly 1/2, no context (spec: "direct bit").
    [[gnu::always_inline]] void encode_direct(int bit) {
        range_ >>= 1;
        low_ += bit ? range_ : 0;
        normalize();
    }
    void finish() {
        for (int i = 0; i < 5; ++i) shift_low();
    }

private:
    [[gnu::always_inline]] void normalize() {
        while (range_ < (1u << 24)) {
            range_ <<= 8;
            shift_low();
        }
    }
    [[gnu::noinline]] void shift_low() {
        if (uint32_t(low_) < 0xFF000000u || (low_ >> 32) != 0) {
            const uint8_t carry = uint8_t(low_ >> 32);
            uint8_t temp = cache_;
            do {
                out_->push_back(std::byte(uint8_t(temp + carry)));
                temp = 0xFF;
            } while (--pending_ != 0);
            cache_ = uint8_t(low_ >> 24);
        }
        ++pending_;
        low_ = (low_ & 0x00FFFFFFu) << 8;
    }
    std::vector<std::byte>* out_;
    uint64_t low_ = 0;
    uint32_t range_ = 0xFFFFFFFFu;
    uint8_t cache_ = 0;
    uint64_t pending_ = 1;
};

class Decoder {
public:
    Decoder(const std::byte* data, std::size_t size) : p_(data), end_(data + size) {
        if (next() != 0) overrun_ = true;  // the first byte is always 0 (spec §7.4)
        for (int i = 0; i < 4; ++i) code_ = (code_ << 8) | next();
    }
    // Inlined into the coders' loops (the compiler would otherwise call it:
    // a fifth of the field decode was call overhead around it), and without
    // a branch on the decoded bit (selects instead), so only the callers'
    // uses of the bit can be mispredicted.
    [[gnu::always_inline]] int decode(Bit& b) {
        const uint32_t bound = (range_ >> 16) * b.p;
        const int bit = code_ >= bound;
        code_ -= bit ? bound : 0;
        range_ = bit ? range_ - bound : bound;
        b.update(bit);
        normalize();
        return bit;
    }
    [[gnu::always_inline]] int decode_direct() {
        range_ >>= 1;
        const int bit = code_ >= range_;
        code_ -= bit ? range_ : 0;
        normalize();
        return bit;
    }
    /// True when the stream ended early or is malformed; also when not all
    /// bytes were consumed (call after the last symbol).
    bool bad_end() const { return overrun_ || p_ != end_; }
    bool overrun() const { return overrun_; }

private:
    [[gnu::always_inline]] void normalize() {
        // At most two steps: a decision shrinks the range by at most 2^16.
        while (range_ < (1u << 24)) {
            range_ <<= 8;
            code_ = (code_ << 8) | next();
        }
    }
    [[gnu::always_inline]] uint32_t next() {
        if (p_ == end_) {
            overrun_ = true;
            return 0;
        }
        return uint32_t(std::to_integer<uint8_t>(*p_++));
    }
    const std::byte* p_;
    const std::byte* end_;
    uint32_t code_ = 0;
    uint32_t range_ = 0xFFFFFFFFu;
    bool overrun_ = false;
};

/// Binarization of a signed integer (spec §7.4 "integer model"): zero flag,
/// sign, bit length by unary, then the bits below the leading one (the top
/// two with contexts, the rest direct). Values up to 64 bits.
struct IntModel {
    Bit zero, sign;
    Bit len[64];
    Bit mant[64][2];
};

/// Bit length of v (0 for 0).
[[gnu::always_inline]] inline int bit_length(uint64_t v) { return v ? 64 - __builtin_clzll(v) : 0; }

/// The head every integer model shares: zero flag, sign, bit length n by unary
/// (len[1 .. maxlen-1]). Returns n (0 for a zero).
[[gnu::always_inline]] inline int encode_int_head(Encoder& e, Bit& zero, Bit& sign, Bit* len, uint64_t mag, bool neg,
                                                  int maxlen) {
    e.encode(zero, mag == 0);
    if (mag == 0) return 0;
    e.encode(sign, neg);
    const int n = bit_length(mag);
    for (int i = 1; i < maxlen; ++i) {  // unary: 1 while n > i
        const int more = n > i;
        e.encode(len[i], more);
        if (!more) break;
    }
    return n;
}

/// Inverse of encode_int_head: n (0 for a zero, then neg is false).
[[gnu::always_inline]] inline int decode_int_head(Decoder& d, Bit& zero, Bit& sign, Bit* len, bool& neg, int maxlen) {
    if (d.decode(zero)) {
        neg = false;
        return 0;
    }
    neg = d.decode(sign) != 0;
    int n = 1;
    while (n < maxlen && d.decode(len[n])) ++n;
    return n;
}

/// mag: |value| (1 .. 2^64-1 or 0); neg: sign. maxlen: the largest possible length.
[[gnu::always_inline]] inline void encode_int(Encoder& e, IntModel& m, uint64_t mag, bool neg, int maxlen) {
    const int n = encode_int_head(e, m.zero, m.sign, m.len, mag, neg, maxlen);
    for (int j = n - 2; j >= 0; --j) {
        const int bit = int((mag >> j) & 1);
        const int pos = n - 2 - j;  // 0 = just below the leading one
        if (pos < 2) e.encode(m.mant[n - 1][pos], bit);
        else e.encode_direct(bit);
    }
}

/// Inverse of encode_int; returns false (value meaningless) when the decoded
/// length exceeds maxlen (cannot happen: the unary code stops at maxlen).
[[gnu::always_inline]] inline void decode_int(Decoder& d, IntModel& m, uint64_t& mag, bool& neg, int maxlen) {
    const int n = decode_int_head(d, m.zero, m.sign, m.len, neg, maxlen);
    if (n == 0) {
        mag = 0;
        return;
    }
    uint64_t v = 1;
    for (int j = n - 2; j >= 0; --j) {
        const int pos = n - 2 - j;
        const int bit = pos < 2 ? d.decode(m.mant[n - 1][pos]) : d.decode_direct();
        v = (v << 1) | uint64_t(bit);
    }
    mag = v;
}

/// Spec §8.4: the integer model of error chunks of mode 7. Zero flag, sign and
/// unary length as IntModel (lengths up to 16), but every bit below the
/// leading one has a context, per (length, position), from a MantissaModel
/// shared by several of these: an error code's low bits are its float
/// exponent's low bits and its mantissa, far from uniform (coded direct,
/// as IntModel does below its top two, they cost a fifth of the error bytes).
struct ShortIntModel {
    Bit zero, sign;
    Bit len[16];
};
struct MantissaModel {
    Bit bit[17][16];  // [length][position below the leading one]
};

/// mag: |value| (0 .. 2^16-1); neg: sign.
[[gnu::always_inline]] inline void encode_short_int(Encoder& e, ShortIntModel& m, MantissaModel& mm, uint32_t mag,
                                                    bool neg) {
    const int n = encode_int_head(e, m.zero, m.sign, m.len, mag, neg, 16);
    for (int j = n - 2; j >= 0; --j) e.encode(mm.bit[n][n - 2 - j], int((mag >> j) & 1));
}

[[gnu::always_inline]] inline void decode_short_int(Decoder& d, ShortIntModel& m, MantissaModel& mm, uint32_t& mag,
                                                    bool& neg) {
    const int n = decode_int_head(d, m.zero, m.sign, m.len, neg, 16);
    if (n == 0) {
        mag = 0;
        return;
    }
    uint32_t v = 1;
    for (int j = n - 2; j >= 0; --j) v = (v << 1) | uint32_t(d.decode(mm.bit[n][n - 2 - j]));
    mag = v;
}

}  // namespace tetlod::rc
