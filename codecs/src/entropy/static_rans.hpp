#pragma once
// Static-table rANS: symbols of an alphabet of up to 129 letters coded with fixed
// frequency tables, one per context, by a range asymmetric numeral system
// (J. Duda, "Asymmetric numeral systems: entropy coding combining speed of
// Huffman coding with compression rate of arithmetic coding", 2013) with a
// 32-bit state, 16-bit renormalisation and two states interleaved point by
// point (F. Giesen, "Interleaved entropy coders", 2014). Beside it, a raw bit
// stream for the bits a symbol does not carry.
//
// Why: the adaptive binary range coder of the HT (ht_codec_entropy.hpp) takes
// 12-45 ns a point to decode, several data-dependent decisions each; issue 13
// asks for 200 MB/s, about 10 ns a u8 point on each of 2 cores. A static table
// decodes a symbol with one mask, one table load, a multiply and a refill
// without a branch (bench_entropy: 4-7 ns a point with both streams), and two
// states let the chains of successive symbols overlap.
//
// Safety on untrusted input: tables are validated when read (read_tables);
// the decoders read copies of their streams padded with zeros and check their
// position every step, so they never read outside and a stream that would
// read past its end sets overrun() instead.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

namespace tetlod::rans {

inline constexpr int kProbBits = 11;                    // probabilities in 1/2048
inline constexpr uint32_t kProbTotal = 1u << kProbBits;
inline constexpr int kMaxSymbols = 129;  // a sign and a bit length up to 64, or 0
inline constexpr uint32_t kStateLow = 1u << 16;  // states live in [2^16, 2^32)

using Counts = std::array<uint64_t, kMaxSymbols>;
/// One context's table: symbol frequencies summing to kProbTotal, or all zero
/// for a context that codes nothing.
using Frequencies = std::array<uint16_t, kMaxSymbols>;

/// Frequencies close to `counts` (deterministic: the same counts give the same
/// table on every machine): every counted symbol gets at least 1, uncounted
/// ones 0, the sum is kProbTotal; all zero when every count is.
Frequencies normalize(const Counts& counts);

/// Appends the coding of `tables` (see read_tables), whose symbols are all
/// below `alphabet` (2..kMaxSymbols), to `out`.
void write_tables(std::span<const Frequencies> tables, int alphabet, std::vector<std::byte>& out);

/// Reads `tables.size()` tables written by write_tables from the start of `in`,
/// bits least significant first: per context a used bit; for a used one the
/// first and the last symbol of non-zero frequency (B bits each, B the bit
/// width of alphabet - 1; first <= last < alphabet), a presence bit for each
/// symbol between them, then the frequency of each present symbol but the last
/// as an Elias-gamma code (the last takes what is left of kProbTotal, at least
/// 1); zero padding to a whole byte. Returns the bytes taken, or nothing when
/// the coding is malformed (truncated, a symbol outside the alphabet, a
/// frequency above what is left, a gamma code of more than 10 zeros, padding
/// that is not zero). Every multi-bit field, the gamma codes' low bits
/// included, is read least significant bit first.
std::optional<std::size_t> read_tables(std::span<const std::byte> in, int alphabet, std::span<Frequencies> tables);

/// Bytes write_tables takes for `tables` (for a writer choosing between codings).
std::size_t tables_size(std::span<const Frequencies> tables, int alphabet);

/// The decoder's view of a set of tables: per used context kProbTotal slots,
/// each packing the symbol of that slot, its frequency and the slot's offset
/// from the symbol's first slot (freq | offset << 12 | symbol << 23), one
/// block after the other, then one block for every unused context (symbol
/// kMaxSymbols, frequency 0). Context c's slots start at base() + block(c) *
/// kProbTotal: a decoding loop copies the block numbers (a byte each) into a
/// local array, which a store of a decoded byte cannot alias (a table of
/// pointers, read through the object, was reloaded after every such store).
/// The slots live in `storage` (a caller's buffer, reused from chunk to
/// chunk: a fresh allocation of this size per chunk was page faults).
class DecodeTables {
public:
    static constexpr std::size_t kMaxContexts = 255;  // block numbers are bytes
    DecodeTables(std::span<const Frequencies> tables, std::vector<uint32_t>& storage);
    const uint32_t* base() const { return base_; }
    uint8_t block(std::size_t c) const { return block_[c]; }
    const uint32_t* context(std::size_t c) const { return base_ + std::size_t(block_[c]) * kProbTotal; }

private:
    const uint32_t* base_ = nullptr;
    std::vector<uint8_t> block_;
};

/// A copy of a stream followed by kPad zero bytes, so that the readers below
/// may load a few bytes past its end without a branch. The bytes live in
/// `storage` (reused by the caller).
class PaddedStream {
public:
    /// Room for kMaxUnchecked symbols of 2 bytes past the end between two
    /// Decoder::check() calls, and for RawBitReader's 8-byte look-ahead.
    static constexpr std::size_t kMaxUnchecked = 64;
    static constexpr std::size_t kPad = 2 * kMaxUnchecked + 32;
    PaddedStream(std::span<const std::byte> in, std::vector<std::byte>& storage) : size_(in.size()) {
        storage.assign(in.size() + kPad, std::byte{0});
        if (!in.empty()) std::memcpy(storage.data(), in.data(), in.size());
        data_ = storage.data();
    }
    const std::byte* begin() const { return data_; }
    const std::byte* end() const { return data_ + size_; }
    std::size_t size() const { return size_; }

private:
    const std::byte* data_ = nullptr;
    std::size_t size_ = 0;
};

/// Codes `symbols[i]` with the table `tables[contexts[i]]` (every one used and
/// giving the symbol a frequency), state i % 2. Returns the stream: the two
/// final states (4 bytes each, little-endian), then 16-bit words little-endian
/// in the order the decoder reads them.
std::vector<std::byte> encode(std::span<const Frequencies> tables, std::span<const uint8_t> contexts,
                              std::span<const uint8_t> symbols);

/// Reads a stream of encode(): next() gives the symbol of the current state
/// from the slots of its context, then makes the other state current, so
/// that successive calls alternate the states as encode() did; check() after
/// every PaddedStream::kMaxUnchecked of them at most, and before the end. A context
/// without a table gives kMaxSymbols (the stream is corrupt). A value type of a
/// few words: a decoding loop keeps a copy in locals (registers).
class Decoder {
public:
    explicit Decoder(const PaddedStream& s) : p_(s.begin()), end_(s.end()) {
        if (s.size() < 8) {
            overrun_ = true;
            p_ = end_;
            return;
        }
        std::memcpy(&x0_, p_, 4);  // little-endian hosts only (static_rans.cpp checks)
        std::memcpy(&x1_, p_ + 4, 4);
        p_ += 8;
        // A valid state is never below kStateLow; one that is would read a
        // word at every step.
        if (x0_ < kStateLow || x1_ < kStateLow) overrun_ = true;
    }

    [[gnu::always_inline]] int next(const uint32_t* slots) {
        uint32_t x = x0_;
        const uint32_t e = slots[x & (kProbTotal - 1)];
        x = (e & 0xFFF) * (x >> kProbBits) + ((e >> 12) & 0x7FF);
        // Refill without a branch on the data: the word is always loaded (the
        // padding makes that safe), kept when the state needs it.
        const uint32_t need = x < kStateLow ? 1u : 0u;
        uint16_t w;
        std::memcpy(&w, p_, 2);
        x = (x << (16 * need)) | (uint32_t(w) & (0u - need));
        p_ += 2 * need;
        x0_ = x1_;
        x1_ = x;
        return int(e >> 23);
    }
    /// Between two calls at most PaddedStream::kMaxUnchecked next(): past the
    /// end they read the padding's zeros, and this notes the overrun and keeps
    /// reading zeros (a per-symbol check cost the loop an instruction a point).
    [[gnu::always_inline]] void check() {
        if (p_ > end_) [[unlikely]]
            overrun_ = true, p_ = end_;
    }

    bool overrun() const { return overrun_ || p_ > end_; }
    /// After the last symbol: true when the stream was exactly what encode()
    /// writes (both states back at their start, every word read).
    bool ended_exactly() const { return !overrun() && p_ == end_ && x0_ == kStateLow && x1_ == kStateLow; }

private:
    const std::byte* p_;
    const std::byte* end_;
    uint32_t x0_ = kStateLow, x1_ = kStateLow;
    bool overrun_ = false;
};

/// Raw bits, least significant first, in a byte stream.
class RawBitWriter {
public:
    void put(uint64_t v, int bits) {  // bits <= 57
        acc_ |= (bits == 0 ? 0 : v & (~uint64_t{0} >> (64 - bits))) << n_;
        n_ += bits;
        while (n_ >= 8) out_.push_back(std::byte(acc_ & 0xFF)), acc_ >>= 8, n_ -= 8;
    }
    /// The bytes, the last one padded with zero bits.
    std::vector<std::byte> finish() {
        if (n_ > 0) out_.push_back(std::byte(acc_ & 0xFF));
        acc_ = 0, n_ = 0;
        return std::move(out_);
    }

private:
    std::vector<std::byte> out_;
    uint64_t acc_ = 0;
    int n_ = 0;
};

/// Reads RawBitWriter's stream: take(n) after refill() gives the next n bits
/// (n <= 56). Past the end it gives zeros and overrun() turns true. A value
/// type, as Decoder.
class RawBitReader {
public:
    explicit RawBitReader(const PaddedStream& s) : p_(s.begin()), begin_(s.begin()), end_(s.end()) {}
    /// At least 56 bits valid after it, without a branch on the data.
    [[gnu::always_inline]] void refill() {
        uint64_t w;
        std::memcpy(&w, p_, 8);
        acc_ |= w << n_;
        p_ += (63 - n_) >> 3;
        n_ |= 56;
        // The accumulator runs up to 8 bytes ahead of the bits taken, so p_ may
        // pass the end on a valid stream; past end_ + 8 it has passed it for
        // sure (the bits taken are 8 (p_ - begin_) - n_ > 8 size), and only
        // loads padding from then on.
        if (p_ > end_ + 8) [[unlikely]]
            p_ = end_ + 8, over_ = true;
    }
    [[gnu::always_inline]] uint64_t take(int bits) {
        const uint64_t v = acc_ & ((uint64_t{1} << bits) - 1);
        acc_ >>= bits;
        n_ -= bits;
        return v;
    }
    /// Whether more bits were taken than the stream holds.
    bool overrun() const { return over_ || taken() > 8 * size(); }
    /// After the last take: true when the stream held exactly the bits taken,
    /// padded to a whole byte with zeros.
    bool ended_exactly() const {
        if (overrun() || (taken() + 7) / 8 != size()) return false;
        const unsigned pad = unsigned(8 * size() - taken());
        return pad == 0 || (uint8_t(begin_[size() - 1]) >> (8 - pad)) == 0;
    }

private:
    uint64_t size() const { return uint64_t(end_ - begin_); }
    // Every byte before p_ went into the accumulator, of which n_ bits are left.
    uint64_t taken() const { return 8 * uint64_t(p_ - begin_) - uint64_t(n_); }
    const std::byte* p_;
    const std::byte* begin_;
    const std::byte* end_;
    uint64_t acc_ = 0;
    int n_ = 0;
    bool over_ = false;
};

}  // namespace tetlod::rans
