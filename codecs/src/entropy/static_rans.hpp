#pragma once
// Static-table rANS: symbols of a 16-letter alphabet coded with fixed
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
inline constexpr int kSymbols = 16;
inline constexpr uint32_t kStateLow = 1u << 16;  // states live in [2^16, 2^32)

using Counts = std::array<uint64_t, kSymbols>;
/// One context's table: symbol frequencies summing to kProbTotal, or all zero
/// for a context that codes nothing.
using Frequencies = std::array<uint16_t, kSymbols>;

/// Frequencies close to `counts` (deterministic: the same counts give the same
/// table on every machine): every counted symbol gets at least 1, uncounted
/// ones 0, the sum is kProbTotal; all zero when every count is.
Frequencies normalize(const Counts& counts);

/// Appends the tables' coding (see read_tables) to `out`.
void write_tables(std::span<const Frequencies> tables, std::vector<std::byte>& out);

/// Reads `tables.size()` tables written by write_tables from the start of `in`:
/// per context a used bit; for a used one 16 presence bits, then each present
/// symbol's frequency but the last as an Elias-gamma code (the last takes what
/// is left of kProbTotal, at least 1); bits least significant first, zero
/// padding to a whole byte. Returns the bytes taken, or nothing when the coding
/// is malformed (truncated, a frequency of 0 or above what is left, a used
/// context with no symbol, padding that is not zero).
std::optional<std::size_t> read_tables(std::span<const std::byte> in, std::span<Frequencies> tables);

/// Bytes write_tables takes for `tables` (for a writer choosing between codings).
std::size_t tables_size(std::span<const Frequencies> tables);

/// The decoder's view of a set of tables: per context kProbTotal slots, each
/// packing the symbol of that slot, its frequency and the slot's offset from
/// the symbol's first slot (freq | offset << 12 | symbol << 23); an unused
/// context's slots hold symbol kSymbols, frequency 0.
class DecodeTables {
public:
    explicit DecodeTables(std::span<const Frequencies> tables);
    const uint32_t* context(std::size_t c) const { return slots_.data() + c * kProbTotal; }

private:
    std::vector<uint32_t> slots_;
};

/// Codes `symbols[i]` with the table `tables[contexts[i]]` (every one used and
/// giving the symbol a frequency), state i % 2. Returns the stream: the two
/// final states (4 bytes each, little-endian), then 16-bit words little-endian
/// in the order the decoder reads them.
std::vector<std::byte> encode(std::span<const Frequencies> tables, std::span<const uint8_t> contexts,
                              std::span<const uint8_t> symbols);

/// Reads a stream of encode(): next<K>() gives the symbol of state K from the
/// slots of its context; a caller alternates K = 0, 1, 0, ... as encode did.
/// A context without a table gives kSymbols (the stream is corrupt).
class Decoder {
public:
    explicit Decoder(std::span<const std::byte> stream) : buf_(stream.size() + kPad) {
        if (!stream.empty()) std::memcpy(buf_.data(), stream.data(), stream.size());
        p_ = buf_.data();
        end_ = buf_.data() + stream.size();
        if (stream.size() < 8) {
            overrun_ = true;
            p_ = end_;
            x_ = {kStateLow, kStateLow};
            return;
        }
        x_[0] = word32();
        x_[1] = word32();
        // A valid state is never below kStateLow; one that is would shrink
        // forever (and read a word at every step).
        if (x_[0] < kStateLow || x_[1] < kStateLow) overrun_ = true;
    }

    template <int K>
    [[gnu::always_inline]] int next(const uint32_t* slots) {
        uint32_t x = x_[K];
        const uint32_t e = slots[x & (kProbTotal - 1)];
        x = (e & 0xFFF) * (x >> kProbBits) + ((e >> 12) & 0x7FF);
        // Refill without a branch on the data: the word is always loaded (the
        // padding makes that safe), kept when the state needs it.
        const uint32_t need = x < kStateLow ? 1u : 0u;
        uint16_t w;
        std::memcpy(&w, p_, 2);
        x = (x << (16 * need)) | (uint32_t(w) & (0u - need));
        p_ += 2 * need;
        if (p_ > end_) [[unlikely]]
            overrun_ = true, p_ = end_;  // reads zeros from now on
        x_[K] = x;
        return int(e >> 23);
    }

    bool overrun() const { return overrun_; }
    /// After the last symbol: true when the stream was exactly what encode()
    /// writes (both states back at their start, every word read).
    bool ended_exactly() const { return !overrun_ && p_ == end_ && x_[0] == kStateLow && x_[1] == kStateLow; }

private:
    static constexpr std::size_t kPad = 16;
    uint32_t word32() {
        uint32_t v;
        std::memcpy(&v, p_, 4);
        p_ += 4;
        return v;  // little-endian hosts only (the build checks)
    }
    std::vector<std::byte> buf_;
    const std::byte* p_ = nullptr;
    const std::byte* end_ = nullptr;
    std::array<uint32_t, 2> x_{kStateLow, kStateLow};
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
/// (n <= 56). Past the end it gives zeros and sets overrun().
class RawBitReader {
public:
    explicit RawBitReader(std::span<const std::byte> in) : buf_(in.size() + kPad) {
        if (!in.empty()) std::memcpy(buf_.data(), in.data(), in.size());
        p_ = buf_.data();
        end_ = buf_.data() + in.size();
    }
    /// At least 56 bits valid after it, without a branch on the data.
    [[gnu::always_inline]] void refill() {
        uint64_t w;
        std::memcpy(&w, p_, 8);
        acc_ |= w << n_;
        p_ += (63 - n_) >> 3;
        n_ |= 56;
        // The accumulator runs up to 8 bytes ahead of the bits taken, so p_ may
        // pass the end on a valid stream; past end_ + 8 it only loads padding.
        if (p_ > end_ + 8) [[unlikely]]
            p_ = end_ + 8;
    }
    [[gnu::always_inline]] uint64_t take(int bits) {
        const uint64_t v = acc_ & ((uint64_t{1} << bits) - 1);
        acc_ >>= bits;
        n_ -= bits;
        consumed_ += uint64_t(bits);
        return v;
    }
    /// Whether more bits were taken than the stream holds.
    bool overrun() const { return consumed_ > 8 * uint64_t(end_ - buf_.data()); }
    /// After the last take: true when the stream held exactly the bits taken,
    /// padded to a byte with zeros.
    bool ended_exactly() const {
        if (overrun()) return false;
        const uint64_t size = uint64_t(end_ - buf_.data());
        if ((consumed_ + 7) / 8 != size) return false;
        const unsigned pad = unsigned(8 * size - consumed_);
        return pad == 0 || (uint8_t(buf_[size - 1]) >> (8 - pad)) == 0;
    }

private:
    static constexpr std::size_t kPad = 24;  // end_ + 8 plus an 8-byte load
    std::vector<std::byte> buf_;
    const std::byte* p_ = nullptr;
    const std::byte* end_ = nullptr;
    uint64_t acc_ = 0;
    int n_ = 0;
    uint64_t consumed_ = 0;
};

}  // namespace tetlod::rans
