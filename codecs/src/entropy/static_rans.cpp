// Static-table rANS (static_rans.hpp): tables and the encoder. The decoder's
// step is inline in the header; what runs once per chunk is here.
#include "static_rans.hpp"

#include <algorithm>
#include <bit>

#include "tetlod/core/error.hpp"

namespace tetlod::rans {

static_assert(std::endian::native == std::endian::little, "the streams are read with memcpy of little-endian words");

namespace {

/// Reads the tables' bits, least significant first; past the end it fails.
class TableBits {
public:
    explicit TableBits(std::span<const std::byte> in) : in_(in) {}
    bool bit(uint32_t& b) {
        if (at_ >= 8 * in_.size()) return false;
        b = (uint8_t(in_[at_ >> 3]) >> (at_ & 7)) & 1u;
        ++at_;
        return true;
    }
    bool bits(int n, uint32_t& v) {
        v = 0;
        for (int k = 0; k < n; ++k) {
            uint32_t b;
            if (!bit(b)) return false;
            v |= b << k;
        }
        return true;
    }
    /// Elias gamma: L - 1 zeros, a one, then the L - 1 bits below the leading one.
    bool gamma(uint32_t& v) {
        int zeros = 0;
        for (uint32_t b = 0;; ++zeros) {
            if (!bit(b)) return false;
            if (b) break;
            if (zeros >= kProbBits - 1) return false;  // no frequency below 2048 has more than 11 bits
        }
        uint32_t rest;
        if (!bits(zeros, rest)) return false;
        v = (1u << zeros) | rest;
        return true;
    }
    /// The bytes taken, when the bits left in the last one are zero.
    std::optional<std::size_t> finish() const {
        const std::size_t bytes = (at_ + 7) / 8;
        const unsigned used = unsigned(at_ & 7);
        if (used != 0 && (uint8_t(in_[bytes - 1]) >> used) != 0) return std::nullopt;
        return bytes;
    }

private:
    std::span<const std::byte> in_;
    std::size_t at_ = 0;
};

void put_gamma(RawBitWriter& w, uint32_t v) {  // v >= 1
    const int len = std::bit_width(v);
    w.put(0, len - 1);
    w.put(1, 1);
    w.put(v, len - 1);
}

std::array<uint16_t, kMaxSymbols> starts_of(const Frequencies& f) {
    std::array<uint16_t, kMaxSymbols> st{};
    uint32_t at = 0;
    for (int s = 0; s < kMaxSymbols; ++s) st[size_t(s)] = uint16_t(at), at += f[size_t(s)];
    return st;
}

/// Bits of the first and last symbol's fields.
int symbol_bits(int alphabet) { return std::bit_width(unsigned(alphabet - 1)); }

void check_alphabet(int alphabet) {
    if (alphabet < 2 || alphabet > kMaxSymbols)
        throw Error(ErrorCode::InvalidArgument, "rans: an alphabet of 2 to 129 symbols");
}

/// First and last symbol of non-zero frequency (-1, -1: unused).
std::pair<int, int> span_of(const Frequencies& f) {
    int lo = -1, hi = -1;
    for (int s = 0; s < kMaxSymbols; ++s)
        if (f[size_t(s)] != 0) hi = s, lo = lo < 0 ? s : lo;
    return {lo, hi};
}

}  // namespace

Frequencies normalize(const Counts& counts) {
    Counts c = counts;
    uint64_t total = 0;
    for (uint64_t n : c) total += n;
    // Products below stay within 64 bits.
    while (total >= (uint64_t{1} << 50)) {
        total = 0;
        for (uint64_t& n : c) n = n == 0 ? 0 : std::max<uint64_t>(1, n >> 1), total += n;
    }
    Frequencies f{};
    if (total == 0) return f;
    int64_t sum = 0;
    int biggest = 0;
    for (int s = 0; s < kMaxSymbols; ++s) {
        const uint64_t n = c[size_t(s)];
        f[size_t(s)] = n == 0 ? 0 : uint16_t(std::max<uint64_t>(1, (n * kProbTotal + total / 2) / total));
        sum += f[size_t(s)];
        if (f[size_t(s)] > f[size_t(biggest)]) biggest = s;
    }
    // The most frequent symbol absorbs the rounding; with many rare symbols
    // lifted to 1 it may not hold the excess alone, so the excess is taken
    // from the largest ones in turn (each keeps at least 1).
    int64_t excess = sum - int64_t(kProbTotal);
    if (excess < 0) f[size_t(biggest)] = uint16_t(int64_t(f[size_t(biggest)]) - excess), excess = 0;
    while (excess > 0) {
        int big = 0;
        for (int s = 1; s < kMaxSymbols; ++s)
            if (f[size_t(s)] > f[size_t(big)]) big = s;
        const int64_t take = std::min<int64_t>(excess, int64_t(f[size_t(big)]) - 1 - int64_t(f[size_t(big)]) / 2);
        f[size_t(big)] = uint16_t(int64_t(f[size_t(big)]) - std::max<int64_t>(take, 1));
        excess -= std::max<int64_t>(take, 1);
    }
    return f;
}

void write_tables(std::span<const Frequencies> tables, int alphabet, std::vector<std::byte>& out) {
    check_alphabet(alphabet);
    const int b = symbol_bits(alphabet);
    RawBitWriter w;
    for (const Frequencies& f : tables) {
        const auto [lo, hi] = span_of(f);
        if (hi >= alphabet) throw Error(ErrorCode::InvalidArgument, "rans: a symbol outside the alphabet");
        w.put(lo >= 0, 1);
        if (lo < 0) continue;
        w.put(uint64_t(lo), b);
        w.put(uint64_t(hi), b);
        for (int s = lo + 1; s < hi; ++s) w.put(f[size_t(s)] != 0, 1);
        for (int s = lo; s < hi; ++s)
            if (f[size_t(s)] != 0) put_gamma(w, f[size_t(s)]);
    }
    const auto bytes = w.finish();
    out.insert(out.end(), bytes.begin(), bytes.end());
}

std::size_t tables_size(std::span<const Frequencies> tables, int alphabet) {
    check_alphabet(alphabet);
    const int b = symbol_bits(alphabet);
    std::size_t bits = 0;
    for (const Frequencies& f : tables) {
        const auto [lo, hi] = span_of(f);
        bits += 1;
        if (lo < 0) continue;
        bits += 2 * size_t(b) + size_t(std::max(0, hi - lo - 1));
        for (int s = lo; s < hi; ++s)
            if (f[size_t(s)] != 0) bits += 2 * size_t(std::bit_width(uint32_t(f[size_t(s)]))) - 1;
    }
    return (bits + 7) / 8;
}

std::optional<std::size_t> read_tables(std::span<const std::byte> in, int alphabet, std::span<Frequencies> tables) {
    check_alphabet(alphabet);
    const int b = symbol_bits(alphabet);
    TableBits r(in);
    for (Frequencies& f : tables) {
        f.fill(0);
        uint32_t used, lo, hi;
        if (!r.bit(used)) return std::nullopt;
        if (!used) continue;
        if (!r.bits(b, lo) || !r.bits(b, hi) || lo > hi || hi >= uint32_t(alphabet)) return std::nullopt;
        f[lo] = 1;  // present (its frequency below)
        for (uint32_t s = lo + 1; s < hi; ++s) {
            uint32_t present;
            if (!r.bit(present)) return std::nullopt;
            f[s] = uint16_t(present);
        }
        uint32_t left = kProbTotal;
        for (uint32_t s = lo; s < hi; ++s) {
            if (f[s] == 0) continue;
            uint32_t v;
            // Each present symbol but the last leaves at least 1 for it.
            if (!r.gamma(v) || v >= left) return std::nullopt;
            f[s] = uint16_t(v);
            left -= v;
        }
        f[hi] = uint16_t(left);
    }
    return r.finish();
}

DecodeTables::DecodeTables(std::span<const Frequencies> tables, std::vector<uint32_t>& storage)
    : block_(tables.size(), 0) {
    if (tables.size() > kMaxContexts) throw Error(ErrorCode::InvalidArgument, "rans: more than 255 contexts");
    std::size_t used = 0;
    for (const Frequencies& f : tables) used += f != Frequencies{};
    storage.resize((used + 1) * kProbTotal);
    uint32_t* slot = storage.data();
    uint8_t next = 0;
    for (std::size_t c = 0; c < tables.size(); ++c) {
        if (tables[c] == Frequencies{}) continue;
        block_[c] = next++;
        uint32_t at = 0;
        for (int s = 0; s < kMaxSymbols; ++s) {
            const uint32_t f = tables[c][size_t(s)];
            for (uint32_t k = 0; k < f && at < kProbTotal; ++k) slot[at++] = f | k << 12 | uint32_t(s) << 23;
        }
        // Tables from read_tables or normalize sum to kProbTotal; any other
        // leaves the rest as unused slots.
        for (; at < kProbTotal; ++at) slot[at] = uint32_t(kMaxSymbols) << 23;
        slot += kProbTotal;
    }
    // The unused contexts' block: a stream that reads it is corrupt (the
    // caller sees kMaxSymbols); the state, 0, stays safe to continue with.
    std::fill(slot, slot + kProbTotal, uint32_t(kMaxSymbols) << 23);
    for (std::size_t c = 0; c < tables.size(); ++c)
        if (tables[c] == Frequencies{}) block_[c] = next;
    base_ = storage.data();
}

std::vector<std::byte> encode(std::span<const Frequencies> tables, std::span<const uint8_t> contexts,
                              std::span<const uint8_t> symbols) {
    if (contexts.size() != symbols.size())
        throw Error(ErrorCode::InvalidArgument, "rans encode: one context per symbol");
    std::vector<std::array<uint16_t, kMaxSymbols>> starts(tables.size());
    for (std::size_t c = 0; c < tables.size(); ++c) starts[c] = starts_of(tables[c]);
    std::vector<uint16_t> words;  // in the reverse of the order they are read
    words.reserve(symbols.size() / 4 + 16);
    std::array<uint32_t, 2> x{kStateLow, kStateLow};
    for (std::size_t i = symbols.size(); i-- > 0;) {
        const std::size_t c = contexts[i];
        const int s = symbols[i];
        if (c >= tables.size() || s >= kMaxSymbols || tables[c][size_t(s)] == 0)
            throw Error(ErrorCode::InvalidArgument, "rans encode: a symbol its context's table does not hold");
        const uint32_t f = tables[c][size_t(s)];
        uint32_t& xi = x[i & 1];
        // After the step the state must stay below 2^32: renormalise first.
        if (uint64_t(xi) >= (uint64_t(kStateLow >> kProbBits) << 16) * f) words.push_back(uint16_t(xi)), xi >>= 16;
        xi = ((xi / f) << kProbBits) + (xi % f) + starts[c][size_t(s)];
    }
    std::vector<std::byte> out(8 + 2 * words.size());
    std::memcpy(out.data(), &x[0], 4);
    std::memcpy(out.data() + 4, &x[1], 4);
    std::byte* o = out.data() + 8;
    for (std::size_t i = words.size(); i-- > 0; o += 2) std::memcpy(o, &words[i], 2);
    return out;
}

}  // namespace tetlod::rans
