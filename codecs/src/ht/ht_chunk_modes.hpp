#pragma once
// Residual coding 3 (spec §6.4): every HT chunk section carries a mode in its
// table Flags, chosen per chunk by the encoder as the smallest of (range-2d
// only when it saves kRange2dMargin bytes)
//   range          the coding-2 stream (§7.5-§8.3), unchanged;
//   constant       every value of the chunk is the same: that one value;
//   samples        the values themselves in point order, in a zstd frame
//                  (the fallback: no chunk costs much more than zstd of it);
//   zero-residual  (field only) every value equals its prediction: no bytes;
//   lattice        (field only, lossy files, format 3.3) every value is a
//                  multiple of the file's step: its indices range coded
//                  (ht_lattice_chunk.hpp);
//   range-2d       (field only, format 3.6) range's stream with the
//                  two-dimensional contexts of §7.6 (ht_field_chunk_coder.hpp);
//   static         (field only, format 3.7) one symbol per point from tables
//                  the chunk carries, static-table rANS: larger, decodes
//                  several times faster; written only when asked for
//                  (fast_decode; ht_static_chunk_coder.hpp);
//   range-exp      (errors only, format 3.8) range's stream with contexts
//                  from the lattice bound's exponent and modelled low bits
//                  (§8.4, ht_error_chunk_coder.hpp): up to 35 % smaller.
// Range coding wins on most chunks; the others bound the cost of constant,
// sparse and incompressible chunks, where the range coder loses to zstd.
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <string>

#include "ht_error_chunk_coder.hpp"
#include "ht_field_chunk_coder.hpp"
#include "ht_lattice_chunk.hpp"
#include "ht_static_chunk_coder.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"

namespace tetlod::ht_detail {

constexpr uint8_t kResidualChunkModes = 3;

enum ChunkMode : uint32_t {
    kModeRange = 0,
    kModeConstant = 1,
    kModeSamples = 2,
    kModeZeroResidual = 3,
    kModeLattice = 4,  // format 3.3
    kModeRange2d = 5,  // format 3.6
    kModeStatic = 6,   // format 3.7
    kModeRangeExp = 7, // format 3.8
};
/// Spec §6.4: constant, zero-residual and static chunks hold at most 2^22 values, so
/// a chunk (96 bytes of table entries at least) expands no more than a zstd frame.
constexpr uint64_t kMaxModelledPoints = uint64_t{1} << 22;

inline const char* chunk_mode_name(uint32_t mode) {
    switch (mode) {
        case kModeRange: return "range";
        case kModeConstant: return "constant";
        case kModeSamples: return "samples";
        case kModeZeroResidual: return "zero-residual";
        case kModeLattice: return "lattice";
        case kModeRange2d: return "range-2d";
        case kModeStatic: return "static";
        case kModeRangeExp: return "range-exp";
        default: return "unknown";
    }
}

/// One coded chunk section: its stored bytes, raw size and table flags.
struct CodedSection {
    std::vector<std::byte> bytes;
    uint64_t raw_size = 0;
    uint32_t flags = tlod::kSectionCritical;
};

inline CodedSection coded(std::vector<std::byte> bytes, uint32_t mode, bool zstd = false, uint64_t raw = 0) {
    CodedSection s;
    s.raw_size = zstd ? raw : bytes.size();
    s.bytes = std::move(bytes);
    s.flags = tlod::kSectionCritical | (mode << tlod::kSectionModeShift) | (zstd ? tlod::kSectionZstd : 0u);
    return s;
}

/// The chunk's values in point order (§6.2), W bytes each, little-endian;
/// `bits(idx)` gives the value at a field index. Row by row: along a row the
/// index advances by a constant, and W is fixed so the store unrolls (the
/// point-wise walk cost ~2% of an encode, for every chunk of both kinds).
template <int W, class Bits>
std::vector<std::byte> gather_chunk(const Geometry& G, const HtChunk& c, Bits&& bits) {
    std::vector<std::byte> out(std::size_t(c.points) * std::size_t(W));
    std::byte* p = out.data();
    G.for_each_row(c.cycle, c.box, [&](int64_t x0, int64_t x1, int64_t step, int64_t y, int64_t z) {
        const int64_t didx = G.index_delta(step, 0, 0);
        int64_t idx = G.index(x0, y, z);
        for (int64_t x = x0; x <= x1; x += step, idx += didx, p += W) tlod::store_le(p, bits(idx), W);
    });
    return out;
}

inline bool all_equal(const std::vector<std::byte>& raw, int w) {
    for (std::size_t i = std::size_t(w); i < raw.size(); ++i)
        if (raw[i] != raw[i % std::size_t(w)]) return false;
    return true;
}

/// Which modes the encoder may choose (tests force one to cover every path).
struct ChunkModeChoice {
    int forced = -1;       // -1: the smallest; else this mode when it can code the chunk, range if not
    int zstd_level = 19;   // level of the samples mode's frames
    double max_error = 0;  // the file's stated bound (spec §5.1): > 0 tries the lattice mode
    bool range_2d = true;  // may choose range-2d (format 3.6) for field chunks
    // Field chunks only in the modes that decode fast (constant, zero-residual,
    // static of format 3.7, samples when smaller than static); chunks above 2^22
    // points (static's limit) as without it.
    bool fast_decode = false;
    bool range_exp = true;  // error chunks in range-exp (format 3.8) rather than range
};

/// Keeps the smaller of `best` and `cand` (the earlier one on a tie, so the
/// choice depends on the chunk alone: same bytes for any thread count).
inline void keep_smaller(CodedSection& best, CodedSection cand) {
    if (cand.bytes.size() < best.bytes.size()) best = std::move(cand);
}

/// zstd at this level first: the samples mode is tried at the chunk's level
/// (19 by default, ~10x slower) only when this frame comes within 25% of the
/// range coder's size. Without the screen the 257^3 bench encode took 47 s
/// instead of 5; with it no file of bench_container changed size.
constexpr int kScreenZstdLevel = 3;

/// The samples mode of a gathered chunk, when it may beat `range_size`.
inline std::optional<CodedSection> samples_mode(const std::vector<std::byte>& raw, std::size_t range_size,
                                                const ChunkModeChoice& o) {
    const bool forced = o.forced == int(kModeSamples);
    auto frame = tlod::zstd_compress(raw, std::min(o.zstd_level, kScreenZstdLevel));
    if (!forced && frame.size() > range_size + range_size / 4 + 16) return std::nullopt;
    if (o.zstd_level > kScreenZstdLevel) frame = tlod::zstd_compress(raw, o.zstd_level);
    return coded(std::move(frame), kModeSamples, true, raw.size());
}

/// Constant or samples coding of a gathered chunk (`n` values of `w` bytes),
/// per `o`; `range` is the range-coded section, the default.
inline CodedSection choose_mode(CodedSection range, const std::vector<std::byte>& raw, uint64_t n, int w,
                                const ChunkModeChoice& o) {
    if (o.forced == int(kModeRange)) return range;
    if ((o.forced < 0 || o.forced == int(kModeConstant)) && n <= kMaxModelledPoints && all_equal(raw, w))
        return coded(std::vector<std::byte>(raw.begin(), raw.begin() + w), kModeConstant);
    if (o.forced >= 0 && o.forced != int(kModeSamples)) return range;  // the forced mode cannot code it
    if (auto samples = samples_mode(raw, range.bytes.size(), o)) {
        if (o.forced == int(kModeSamples)) return std::move(*samples);
        keep_smaller(range, std::move(*samples));
    }
    return range;
}

/// Whether every value of the chunk equals its prediction (§7.4).
template <class T>
bool zero_residuals(const Geometry& G, const T* v, const HtChunk& c) {
    using D = Dom<T>;
    struct Check {
        const T* v;
        bool zero = true;
        void operator()(int, const Prediction& pr, int64_t idx, int64_t) {
            zero = zero && typename D::U(uint64_t(D::get(v[idx]))) == typename D::U(uint64_t(pr.p));
        }
    } check{v};
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    walk_field_chunk(G, v, c, lat, check);
    return check.zero;
}

/// A field chunk for fast decoding (ChunkModeChoice::fast_decode): constant
/// when every value is the same, zero-residual when every value is its
/// prediction, else static, or samples where zstd makes it smaller (zstd
/// decodes at about 1 GB/s). The range modes are not tried: they are the slow
/// ones. Lossy files' lattice mode neither: its indices are range coded.
template <class T>
CodedSection encode_field_chunk_fast(const Geometry& G, const T* v, const HtChunk& c, const ChunkModeChoice& o) {
    using D = Dom<T>;
    constexpr int w = int(sizeof(T));
    const auto raw = gather_chunk<w>(G, c, [&](int64_t i) { return uint64_t(std::bit_cast<typename D::U>(v[i])); });
    if (all_equal(raw, w)) return coded(std::vector<std::byte>(raw.begin(), raw.begin() + w), kModeConstant);
    StaticChunk st = encode_static_chunk<T>(G, v, c);
    if (st.zero_residuals) return coded({}, kModeZeroResidual);
    CodedSection best = coded(std::move(st.bytes), kModeStatic);
    if (auto samples = samples_mode(raw, best.bytes.size(), o)) keep_smaller(best, std::move(*samples));
    return best;
}

/// Bytes a range-2d stream must save over mode 0's to be kept (see
/// encode_field_chunk_v3).
constexpr std::size_t kRange2dMargin = 4;

template <class T>
CodedSection encode_field_chunk_v3(const Geometry& G, const T* v, const HtChunk& c, ChunkModeChoice o) {
    using D = Dom<T>;
    constexpr int w = int(sizeof(T));
    if (c.points == 0) return coded({}, kModeRange);
    if (o.forced == int(kModeRange)) return coded(encode_field_chunk_v2<T>(G, v, c), kModeRange);
    if (o.forced == int(kModeRange2d)) return coded(encode_field_chunk_v2<T, true>(G, v, c), kModeRange2d);
    if (o.forced == int(kModeStatic))
        return c.points <= kMaxModelledPoints ? coded(encode_static_chunk<T>(G, v, c).bytes, kModeStatic)
                                              : coded(encode_field_chunk_v2<T>(G, v, c), kModeRange);
    if (o.fast_decode && o.forced < 0 && c.points <= kMaxModelledPoints) return encode_field_chunk_fast<T>(G, v, c, o);
    // Both context sets, the two-dimensional one kept only when it saves at
    // least kRange2dMargin bytes: a file is 3.6 only when it pays, and a section
    // whose mode differs from its neighbours' costs about a byte of the
    // compressed table (on 33^3 noise in 2-step bricks, a 1-byte margin gave a
    // larger file than range alone). A forced mode falls back on mode 0, as
    // before 3.6.
    CodedSection range;
    if (o.forced < 0 && o.range_2d) {
        auto [stream1, stream2] = encode_field_chunk_both<T>(G, v, c);
        const bool two_d = stream2.size() + kRange2dMargin <= stream1.size();
        range = two_d ? coded(std::move(stream2), kModeRange2d) : coded(std::move(stream1), kModeRange);
    } else {
        range = coded(encode_field_chunk_v2<T>(G, v, c), kModeRange);
    }
    // Zero residuals range-code to a few bytes per context; only such small
    // streams are worth the extra prediction pass (a linear chunk then costs nothing).
    const bool small = range.bytes.size() <= 16 + c.points / 256;
    if (c.points <= kMaxModelledPoints && (o.forced == int(kModeZeroResidual) || (o.forced < 0 && small)) &&
        zero_residuals(G, v, c))
        return coded({}, kModeZeroResidual);
    if (o.forced == int(kModeZeroResidual)) return range;  // it cannot code the chunk
    auto lattice = [&]() -> std::optional<CodedSection> {
        const double step = lattice_step<T>(o.max_error);
        if (!(step > 0)) return std::nullopt;
        auto bytes = encode_lattice_chunk<T>(G, v, c, step);
        if (!bytes) return std::nullopt;
        return coded(std::move(*bytes), kModeLattice);
    };
    if (o.forced == int(kModeLattice)) {
        auto l = lattice();
        return l ? std::move(*l) : range;
    }
    const auto raw = gather_chunk<w>(G, c, [&](int64_t i) { return uint64_t(std::bit_cast<typename D::U>(v[i])); });
    CodedSection best = choose_mode(std::move(range), raw, c.points, w, o);
    // Last, so a tie keeps the earlier modes (and a 3.3 file only when it pays).
    if (o.forced < 0 && tlod::section_mode(best.flags) != kModeConstant)
        if (auto l = lattice()) keep_smaller(best, std::move(*l));
    return best;
}

/// Error chunks with at least this many diamonds code range and range-exp
/// in parallel (below, the task costs more than it saves).
constexpr std::size_t kParallelErrorCodingSymbols = 4096;

template <class T>
CodedSection encode_error_chunk_v3(const Geometry& G, const T* v, std::span<const float> e, const HtChunk& c,
                                   int m, ChunkModeChoice o) {
    if (c.diamonds == 0) return coded({}, kModeRange);
    if (o.forced == int(kModeZeroResidual) || o.forced == int(kModeLattice) || o.forced == int(kModeRange2d) ||
        o.forced == int(kModeStatic))
        o.forced = int(kModeRange);  // field-only modes
    thread_local std::vector<ErrorSymbol> sym;
    gather_error_symbols(G, v, e, c, m, sym);
    if (o.forced == int(kModeRangeExp)) return coded(code_error_symbols<true>(sym, m), kModeRangeExp);
    // Both coders on the same symbols, the smaller kept (range on a tie):
    // range-exp's larger set of contexts loses where there is little to learn
    // (float chunks whose bounds are nearly all exact, as m4's cycle 0: +90
    // bytes), and the zstd trial's screen (samples_mode) rejects more chunks
    // the smaller the range size is.
    CodedSection range;
    if (o.range_exp && o.forced < 0) {
        // The two codings are independent reads of the symbols: on two cores
        // when the chunk is large enough to pay for the task (a small volume's
        // cycles are one chunk each, and their codings were its longest tasks).
        // The symbols are this thread's thread_local: the tasks reach them
        // through a reference (in another thread the name is another vector),
        // and the wait is isolated so that this thread starts no other chunk.
        const std::vector<ErrorSymbol>& symbols = sym;
        auto plain = [&] { range = coded(code_error_symbols<false>(symbols, m), kModeRange); };
        CodedSection range_exp;
        auto exp = [&] { range_exp = coded(code_error_symbols<true>(symbols, m), kModeRangeExp); };
        if (symbols.size() >= kParallelErrorCodingSymbols) {
            tbb::this_task_arena::isolate([&] { tbb::parallel_invoke(plain, exp); });
        } else {
            plain();
            exp();
        }
        keep_smaller(range, std::move(range_exp));
    } else {
        range = coded(code_error_symbols<false>(sym, m), kModeRange);
    }
    if (o.forced == int(kModeRange)) return range;
    const auto raw =
        gather_chunk<2>(G, c, [&](int64_t i) { return uint64_t(quantize_error(e[std::size_t(i)], m)); });
    return choose_mode(std::move(range), raw, c.diamonds, 2, o);
}

/// Decodes a field chunk of coding 3 from its raw bytes (decompressed when
/// the section is flagged ZSTD). The layout checked the sizes against the
/// mode (§6.4); `lattice_step` is the file's (lattice_step<T>, 0 if none).
/// Returns an empty string or what is wrong.
template <class T>
std::string decode_field_chunk_v3(const Geometry& G, T* v, const HtChunk& c, uint32_t mode,
                                  std::span<const std::byte> in, double lattice_step) {
    using D = Dom<T>;
    using U = typename D::U;
    constexpr int w = int(sizeof(T));
    switch (mode) {
        case kModeRange:
            return decode_field_chunk_v2<T>(G, v, c, in) ? "" : "malformed range-coded stream";
        case kModeConstant: {
            if (in.size() != std::size_t(w)) return "constant chunk of the wrong size";
            const T value = std::bit_cast<T>(U(tlod::load_le(in.data(), w)));
            G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) { v[G.index(x, y, z)] = value; });
            return "";
        }
        case kModeSamples: {
            if (in.size() != c.points * uint64_t(w)) return "samples chunk of the wrong size";
            const std::byte* p = in.data();
            G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
                v[G.index(x, y, z)] = std::bit_cast<T>(U(tlod::load_le(p, w)));
                p += w;
            });
            return "";
        }
        case kModeZeroResidual: {
            if (!in.empty()) return "zero-residual chunk with stored bytes";
            struct Put {
                T* v;
                void operator()(int, const Prediction& pr, int64_t idx, int64_t) { v[idx] = D::put(U(uint64_t(pr.p))); }
            } put{v};
            thread_local std::vector<uint32_t> storage;
            ChunkLattice lat(c.cycle, c.box, storage);
            walk_field_chunk(G, v, c, lat, put);
            return "";
        }
        case kModeLattice:
            return decode_lattice_chunk<T>(G, v, c, lattice_step, in);
        case kModeRange2d:
            return decode_field_chunk_v2<T, true>(G, v, c, in) ? "" : "malformed range-coded stream";
        case kModeStatic:
            return decode_static_chunk<T>(G, v, c, in);
        default:
            return "unknown chunk mode " + std::to_string(mode);
    }
}

/// As decode_field_chunk_v3, for the error codes; the chunk's field is decoded.
template <class T>
std::string decode_error_chunk_v3(const Geometry& G, const T* v, float* e, const HtChunk& c, int m, uint32_t mode,
                                  std::span<const std::byte> in) {
    const uint32_t qmax = max_error_code(m);
    auto scatter = [&](auto&& code_at) {
        bool ok = true;
        std::size_t i = 0;
        G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
            const uint64_t q = code_at(i++);
            ok = ok && q <= qmax;
            e[G.index(x, y, z)] = q <= qmax ? dequantize_error(uint16_t(q), m) : std::numeric_limits<float>::infinity();
        });
        return ok ? std::string() : "error code above " + std::to_string(qmax);
    };
    switch (mode) {
        case kModeRange:
            return decode_error_chunk_v2<T>(G, v, e, c, m, in) ? "" : "error code out of range or malformed stream";
        case kModeRangeExp:
            return decode_error_chunk_v2<T, true>(G, v, e, c, m, in) ? ""
                                                                    : "error code out of range or malformed stream";
        case kModeConstant:
            if (in.size() != 2) return "constant chunk of the wrong size";
            return scatter([&](std::size_t) { return tlod::load_le(in.data(), 2); });
        case kModeSamples:
            if (in.size() != c.diamonds * 2) return "samples chunk of the wrong size";
            return scatter([&](std::size_t i) { return tlod::load_le(in.data() + 2 * i, 2); });
        default:
            return "unknown chunk mode " + std::to_string(mode) + " for error codes";
    }
}

}  // namespace tetlod::ht_detail
