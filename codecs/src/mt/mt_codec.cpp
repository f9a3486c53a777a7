// MT serialization (docs/mt.md §5, spec/tlod-format.md §10). Layout, all little-endian:
//   header (48 bytes): "TLMT", u16 coding, u16 flags (bit 0: field included;
//     others reserved, must be 0), u32 dims x,y,z, u8 value type, u8 mantissa bits,
//     u16 reserved (0), u32 base tets, u32 updates, u64 raw payload size,
//     u64 stored payload size
//   payload: one zstd frame; raw = streams, each u64 length + bytes.
//   Coding 1 (read only): 7 streams: base, offsets (3 zigzag varints per update),
//     labels, errors (u16 codes), stars, masks (cut, exception count, gaps), field.
//   Coding 2 (read; written on request): the same content in 11 streams, each
//     holding one kind of symbol, because zstd's literal coder is order-0 per
//     block: mixing small offsets with varint escapes, or the high and low bytes
//     of error codes, or a mask's cut with its gaps, blurs the statistics it can
//     exploit (2-10 % fewer bytes on the real volumes of the bench):
//     0 base, 1 near offsets (one byte per update: (dx+2) + 5(dy+2) + 25(dz+2)
//     when every component is in -2..2, else 125), 2 far offsets (3 zigzag varints
//     per update whose near byte is 125), 3 labels, 4 error code high bytes,
//     5 error code low bytes, 6 stars, 7 mask cuts, 8 mask exception counts,
//     9 mask exceptions (the first as a signed offset from the cut, where the
//     exceptions cluster; then gaps), 10 field.
//   Coding 3 (written): 12 streams. Labels split into their low byte and a varint
//     of the rest (a byte plane codes better than varints whose first byte mixes
//     both), and error codes listed in increasing label order (ties in raster
//     order), where they follow the decimation's order and nearly sort:
//     0 base, 1 near offsets, 2 far offsets, 3 label low bytes, 4 label high
//     parts (varint label >> 8), 5 error code high bytes, 6 error code low bytes
//     (both in label order), 7 stars, 8 mask cuts, 9 mask exception counts,
//     10 mask exceptions, 11 field.
// Updates appear in raster order of their inserted point w, which is every grid
// point that is not a vertex of the base mesh.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <tbb/parallel_for.h>

#include "tetlod/models/detail/mt_geometry.hpp"
#include "tetlod/codecs/error_quantizer.hpp"
#include "tetlod/codecs/lossy_field.hpp"
#include "tetlod/core/varint.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/format/container.hpp"

namespace tetlod {

namespace {

constexpr size_t kHeaderSize = 48;
constexpr int kStreamsCoding1 = 7;
constexpr int kStreamsCoding2 = 11;
constexpr int kStreamsCoding3 = 12;
constexpr int kMaxStreams = kStreamsCoding3;
/// Near-offset byte of codings 2 and 3 that sends the offset to the far stream.
constexpr uint8_t kFarOffset = 125;

int stream_count(uint64_t coding) {
    return coding == 1 ? kStreamsCoding1 : coding == 2 ? kStreamsCoding2 : kStreamsCoding3;
}

/// Positions 0..n-1 ordered by increasing label, ties in increasing position
/// (coding 3's order of the error codes). A stable LSD radix sort on 16-bit
/// digits: linear in n, so decoding a large MT does not pay an n log n sort.
std::vector<uint32_t> label_order(const std::vector<uint32_t>& labels) {
    const size_t n = labels.size();
    std::vector<uint32_t> order(n), tmp(n);
    for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
    uint32_t top = 0;
    for (uint32_t l : labels) top = std::max(top, l);
    for (int shift = 0; shift < 32 && (shift == 0 || (top >> shift) != 0); shift += 16) {
        std::vector<uint32_t> count(65537, 0);
        for (uint32_t i : order) ++count[((labels[i] >> shift) & 0xFFFF) + 1];
        for (size_t d = 1; d < count.size(); ++d) count[d] += count[d - 1];
        for (uint32_t i : order) tmp[count[(labels[i] >> shift) & 0xFFFF]++] = i;
        order.swap(tmp);
    }
    return order;
}

void put_le(std::vector<uint8_t>& o, uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) o.push_back(uint8_t(v >> (8 * i)));
}
void put_le_bytes(std::vector<std::byte>& o, uint64_t v) {
    for (int i = 0; i < 8; ++i) o.push_back(std::byte(uint8_t(v >> (8 * i))));
}

struct Reader {
    const uint8_t* p;
    const uint8_t* end;
    bool ok = true;
    size_t left() const { return size_t(end - p); }
    uint64_t le(int bytes) {
        if (left() < size_t(bytes)) return ok = false, 0;
        uint64_t v = 0;
        for (int i = 0; i < bytes; ++i) v |= uint64_t(p[i]) << (8 * i);
        p += bytes;
        return v;
    }
    uint64_t varint() {
        uint64_t v = 0;
        for (int shift = 0; shift < 64; shift += 7) {
            if (p == end) return ok = false, 0;
            const uint8_t b = *p++;
            v |= uint64_t(b & 0x7F) << shift;
            if (!(b & 0x80)) return v;
        }
        return ok = false, 0;
    }
};

/// Cut c minimising exceptions: ones expected in [0, c), zeros in [c, d).
void encode_mask(const MtModel& m, size_t k, std::vector<uint8_t>& cuts, std::vector<uint8_t>& counts,
                 std::vector<uint8_t>& gaps) {
    const uint32_t d = m.updates()[k].star;
    const uint64_t at = m.mask_offset(k);
    uint32_t best_c = 0, ones_total = 0;
    for (uint32_t i = 0; i < d; ++i) ones_total += m.mask_bit(at + i);
    // exceptions(c) = zeros in [0,c) + ones in [c,d)
    uint32_t zeros_before = 0, ones_before = 0, best_exc = ones_total;
    for (uint32_t c = 1; c <= d; ++c) {
        if (m.mask_bit(at + c - 1)) ++ones_before;
        else ++zeros_before;
        const uint32_t exc = zeros_before + (ones_total - ones_before);
        if (exc < best_exc) best_exc = exc, best_c = c;
    }
    put_varint(cuts, best_c);
    put_varint(counts, best_exc);
    // Exceptions cluster around the cut: the first is coded from it (signed), the
    // others as gaps from the previous one.
    uint32_t prev = 0;
    bool first = true;
    for (uint32_t i = 0; i < d; ++i) {
        const bool expect = i < best_c;
        if (m.mask_bit(at + i) == expect) continue;
        put_varint(gaps, first ? zigzag(int64_t(i) - int64_t(best_c)) : i - prev);
        prev = i, first = false;
    }
}

/// Where each symbol kind of an update comes from: the streams of coding 1, 2 or 3.
struct UpdateStreams {
    Reader* near = nullptr;  // coding 2 only
    Reader* far = nullptr;   // coding 1: every offset
    Reader* labels = nullptr;
    Reader* errors_hi = nullptr;  // coding 1: the u16 codes
    Reader* errors_lo = nullptr;  // coding 2 only
    Reader* stars = nullptr;
    Reader* cuts = nullptr;  // coding 1: cuts, counts and gaps interleaved
    Reader* counts = nullptr;
    Reader* gaps = nullptr;

    static UpdateStreams of(uint64_t coding, Reader* st) {
        if (coding == 1) return {nullptr, &st[1], &st[2], &st[3], nullptr, &st[4], &st[5], &st[5], &st[5]};
        if (coding == 2) return {&st[1], &st[2], &st[3], &st[4], &st[5], &st[6], &st[7], &st[8], &st[9]};
        // Coding 3: labels and error codes are read up front (label_order), not here.
        return {&st[1], &st[2], nullptr, nullptr, nullptr, &st[7], &st[8], &st[9], &st[10]};
    }
    /// s - w; false when a stream is exhausted or a near byte is out of range.
    bool offset(int64_t out[3]) {
        if (near) {
            const uint64_t b = near->le(1);
            if (!near->ok || b > kFarOffset) return false;
            if (b < kFarOffset) {
                out[0] = int64_t(b % 5) - 2, out[1] = int64_t(b / 5 % 5) - 2, out[2] = int64_t(b / 25) - 2;
                return true;
            }
        }
        for (int a = 0; a < 3; ++a) out[a] = unzigzag(far->varint());
        // A far offset that fits the near byte is a non-canonical encoding.
        bool fits_near = true;
        for (int a = 0; a < 3; ++a) fits_near = fits_near && out[a] >= -2 && out[a] <= 2;
        if (near && fits_near) return false;
        return far->ok;
    }
    uint64_t error_code() {
        if (!errors_lo) return errors_hi->le(2);
        return (errors_hi->le(1) << 8) | errors_lo->le(1);
    }
};

/// Coding 2's payload (per stream: u64 raw length, u64 frame length, the zstd
/// frame, absent when the stream is empty) decompressed into coding 1's layout
/// (per stream: u64 length, bytes), so one parser reads both. The raw lengths
/// must add up to `raw_size`, already checked against the header's counts.
Expected<std::vector<std::byte>> join_stream_frames(std::span<const std::byte> payload, int nstreams,
                                                    uint64_t raw_size) {
    Reader r{reinterpret_cast<const uint8_t*>(payload.data()),
             reinterpret_cast<const uint8_t*>(payload.data()) + payload.size()};
    std::vector<std::byte> raw;
    uint64_t claimed = 0;
    for (int i = 0; i < nstreams; ++i) {
        const uint64_t len = r.le(8), frame = r.le(8);
        if (!r.ok) return fail(ErrorCode::Truncated, "stream " + std::to_string(i) + ": header truncated");
        if (frame > r.left()) return fail(ErrorCode::Truncated, "stream " + std::to_string(i) + ": frame truncated");
        if (len > raw_size) return fail(ErrorCode::CorruptData, "stream lengths exceed the raw payload size");
        claimed += 8 + len;  // no overflow: len <= raw_size, and claimed <= raw_size before
        if (claimed > raw_size)
            return fail(ErrorCode::CorruptData, "stream lengths exceed the raw payload size");
        if ((len == 0) != (frame == 0))
            return fail(ErrorCode::CorruptData, "stream " + std::to_string(i) + ": empty stream with a frame or the reverse");
        put_le_bytes(raw, len);
        if (len != 0) {
            auto part = tlod::zstd_decompress(std::as_bytes(std::span(r.p, size_t(frame))), len);
            if (!part) return with_context("stream " + std::to_string(i) + ": ", part.failure());
            raw.insert(raw.end(), part->begin(), part->end());
            r.p += frame;
        }
    }
    if (r.left() != 0) return fail(ErrorCode::CorruptData, "trailing bytes after the last stream");
    if (claimed != raw_size) return fail(ErrorCode::CorruptData, "stream lengths differ from the raw payload size");
    return raw;
}

}  // namespace

std::vector<uint8_t> encode_mt(const MtModel& m, const MtEncodeOptions& opt) {
    if (opt.coding != 2 && opt.coding != 3)
        throw Error(ErrorCode::InvalidArgument, "MT: coding " + std::to_string(opt.coding) + " cannot be written (2 or 3)");
    if (!(opt.field_error >= 0) || !std::isfinite(opt.field_error))
        throw Error(ErrorCode::InvalidArgument, "MT: the field's error bound must be finite and >= 0");
    const bool c3 = opt.coding == 3;
    const int nstreams = stream_count(uint64_t(opt.coding));
    const Dims& D = m.dims();
    const mt::Grid g(D);
    const int mb = std::clamp(opt.error_mantissa_bits, 0, 7);
    std::vector<uint8_t> s[kMaxStreams];
    // Coding 2: 3 labels, 4/5 error bytes, 6.. the rest; coding 3 (file comment):
    // 3/4 label parts, 5/6 error bytes, 7.. the rest.
    const int after = c3 ? 7 : 6;
    std::vector<uint8_t>&near = s[1], &far = s[2], &labels = s[3], &label_hi = s[4], &errors_hi = s[c3 ? 5 : 4],
                           &errors_lo = s[c3 ? 6 : 5], &stars = s[after], &cuts = s[after + 1],
                           &counts = s[after + 2], &gaps = s[after + 3], &field = s[nstreams - 1];
    for (const auto& t : m.base_tets())
        for (uint32_t v : t) put_le(s[0], v, 4);
    std::vector<uint32_t> by_w(size_t(D.count()), mt::kNil);
    for (size_t k = 0; k < m.updates().size(); ++k) by_w[m.updates()[k].w] = uint32_t(k);
    std::vector<uint32_t> label_of;  // coding 3: per update in raster order
    std::vector<uint16_t> code_of;
    if (c3) label_of.reserve(m.updates().size()), code_of.reserve(m.updates().size());
    for (uint32_t w = 0; w < by_w.size(); ++w) {
        if (by_w[w] == mt::kNil) continue;
        const MtSplit& u = m.updates()[by_w[w]];
        const mt::Pt pw = g.coord(w), ps = g.coord(m.survivor(by_w[w]));
        int64_t d[3];
        bool fits_near = true;
        for (int a = 0; a < 3; ++a) d[a] = int64_t(ps[a]) - pw[a], fits_near = fits_near && d[a] >= -2 && d[a] <= 2;
        if (fits_near) {
            near.push_back(uint8_t((d[0] + 2) + 5 * (d[1] + 2) + 25 * (d[2] + 2)));
        } else {
            near.push_back(kFarOffset);
            for (int a = 0; a < 3; ++a) put_varint(far, zigzag(d[a]));
        }
        const uint16_t code = quantize_error(opt.field_error > 0 ? bound_against_original(u.error, opt.field_error) : u.error, mb);
        if (c3) {
            labels.push_back(uint8_t(u.label));
            put_varint(label_hi, u.label >> 8);
            label_of.push_back(u.label), code_of.push_back(code);
        } else {
            put_varint(labels, u.label);
            errors_hi.push_back(uint8_t(code >> 8)), errors_lo.push_back(uint8_t(code));
        }
        put_varint(stars, u.star);
        encode_mask(m, by_w[w], cuts, counts, gaps);
    }
    if (c3)
        for (uint32_t i : label_order(label_of))
            errors_hi.push_back(uint8_t(code_of[i] >> 8)), errors_lo.push_back(uint8_t(code_of[i]));
    if (opt.include_field) {
        const auto* b = reinterpret_cast<const uint8_t*>(m.field().data.data());
        field.assign(b, b + m.field().data.size());
    }
    // Each stream is its own zstd frame: measured on the bench volumes, one frame
    // over all streams costs 3-6 % more (its blocks straddle streams).
    // The frames are compressed in parallel (a frame depends on its stream
    // only, so the bytes are the same for any thread count): at level 19 they
    // were a tenth of a 129^3 convert's CPU, on one core.
    std::vector<std::byte> frames[kMaxStreams];
    auto level_of = [&](const std::vector<uint8_t>& stream) {
        if (opt.large_stream_zstd_level <= 0 || stream.size() <= opt.large_stream_bytes) return opt.zstd_level;
        return std::min(opt.zstd_level, opt.large_stream_zstd_level);
    };
    tbb::parallel_for(0, nstreams, [&](int i) {
        if (!s[i].empty()) frames[i] = tlod::zstd_compress(std::as_bytes(std::span(s[i])), level_of(s[i]));
    });
    uint64_t raw_size = 0;
    std::vector<uint8_t> z;
    const bool stats = std::getenv("TETLOD_MT_STATS") != nullptr;
    for (const auto& st : std::span(s, size_t(nstreams))) {
        raw_size += 8 + st.size();
        const std::vector<std::byte>& frame = frames[&st - s];
        if (stats)
            std::fprintf(stderr, "mt encode: stream %zu: %zu bytes raw, %zu stored (zstd level %d)\n", size_t(&st - s),
                         st.size(), frame.size(), st.empty() ? 0 : level_of(st));
        put_le(z, st.size(), 8);
        put_le(z, frame.size(), 8);
        const auto* fb = reinterpret_cast<const uint8_t*>(frame.data());
        z.insert(z.end(), fb, fb + frame.size());
    }
    std::vector<uint8_t> out;
    out.reserve(kHeaderSize + z.size());
    for (char c : {'T', 'L', 'M', 'T'}) out.push_back(uint8_t(c));  // (insert trips a GCC 12 false -Wstringop-overflow)
    put_le(out, uint64_t(opt.coding), 2);
    put_le(out, opt.include_field ? 1 : 0, 2);
    put_le(out, uint64_t(D.x), 4), put_le(out, uint64_t(D.y), 4), put_le(out, uint64_t(D.z), 4);
    put_le(out, uint8_t(m.field().type), 1);
    put_le(out, uint64_t(mb), 1);
    put_le(out, 0, 2);
    put_le(out, m.base_tets().size(), 4);
    put_le(out, m.updates().size(), 4);
    put_le(out, raw_size, 8);
    put_le(out, z.size(), 8);
    out.insert(out.end(), z.begin(), z.end());
    return out;
}

Expected<MtModel> decode_mt(std::span<const uint8_t> bytes, const Volume* field) {
    if (bytes.size() < kHeaderSize) return fail(ErrorCode::Truncated, "MT: header truncated");
    if (std::memcmp(bytes.data(), "TLMT", 4) != 0) return fail(ErrorCode::BadMagic, "MT: bad magic");
    Reader h{bytes.data() + 4, bytes.data() + kHeaderSize};
    const uint64_t version = h.le(2), flags = h.le(2);
    if (version < 1 || version > kMtCodecVersion)
        return fail(ErrorCode::UnsupportedVersion, "MT: unsupported version " + std::to_string(version));
    const int nstreams = stream_count(version);
    if (flags & ~uint64_t(1)) return fail(ErrorCode::CorruptData, "MT: reserved flag bits set");
    Dims D{int64_t(h.le(4)), int64_t(h.le(4)), int64_t(h.le(4))};
    const uint64_t type = h.le(1), mb = h.le(1), reserved = h.le(2);
    const uint64_t nbase = h.le(4), nupd = h.le(4), raw_size = h.le(8), stored = h.le(8);
    if (reserved != 0) return fail(ErrorCode::CorruptData, "MT: reserved header bytes not zero");
    if (D.x < 2 || D.y < 2 || D.z < 2 || D.x > 4096 || D.y > 4096 || D.z > 4096 || D.count() >= (int64_t(1) << 31))
        return fail(ErrorCode::TooLarge, "MT: unusable dims");
    if (type < 1 || type > 8) return fail(ErrorCode::CorruptData, "MT: bad value type");
    if (mb > 7) return fail(ErrorCode::CorruptData, "MT: bad mantissa bits");
    const uint64_t n = uint64_t(D.count());
    const ValueType vt = ValueType(type);
    if (nupd >= n || nbase == 0 || nbase > 5 * n) return fail(ErrorCode::CorruptData, "MT: bad counts");
    // Every grid point is a base vertex (at most 4 per base tet) or removed by an
    // update: dims claiming more points than that are refused before the
    // per-point tables are allocated.
    if (n > nupd + 4 * nbase)
        return fail(ErrorCode::CorruptData, "MT: " + std::to_string(n) + " grid points but only " +
                                                std::to_string(nbase) + " base tets and " + std::to_string(nupd) +
                                                " updates");
    if (stored != bytes.size() - kHeaderSize)
        return fail(stored > bytes.size() - kHeaderSize ? ErrorCode::Truncated : ErrorCode::CorruptData,
                    "MT: payload size mismatch");
    // The raw payload holds at least 16 bytes per base tet, 7 per update (an
    // offset (codings 2, 3: one near byte; coding 1: 3 varints), a label (coding
    // 3: a low byte and a varint), a 2-byte error code, a star size, a mask cut
    // and exception count) and the field; at most a generous 64 per update.
    const uint64_t field_bytes = (flags & 1) ? n * value_size(vt) : 0;
    const uint64_t min_raw = 8 * uint64_t(nstreams) + 16 * nbase + (version == 1 ? 9 : version == 2 ? 7 : 8) * nupd + field_bytes;
    const uint64_t max_raw = 8 * uint64_t(nstreams) + 16 * nbase + 64 * nupd + field_bytes + (uint64_t(1) << 16);
    if (raw_size > max_raw) return fail(ErrorCode::TooLarge, "MT: payload larger than its counts allow");
    if (raw_size < min_raw)
        return fail(ErrorCode::CorruptData, "MT: a payload of " + std::to_string(raw_size) +
                                                " bytes cannot hold the header's counts (at least " +
                                                std::to_string(min_raw) + " bytes)");
    // zstd_decompress refuses a raw size the stored bytes cannot expand to and
    // grows its output with the data, so the counts are now backed by bytes.
    const std::span<const std::byte> payload(reinterpret_cast<const std::byte*>(bytes.data() + kHeaderSize), stored);
    auto raw_r = version == 1 ? tlod::zstd_decompress(payload, raw_size) : join_stream_frames(payload, nstreams, raw_size);
    if (!raw_r) return with_context("MT: payload: ", raw_r.failure());
    const std::vector<std::byte>& raw = raw_r.value();
    Reader r{reinterpret_cast<const uint8_t*>(raw.data()), reinterpret_cast<const uint8_t*>(raw.data()) + raw.size()};
    Reader st[kMaxStreams];
    for (int i = 0; i < nstreams; ++i) {
        Reader& x = st[i];
        const uint64_t len = r.le(8);
        if (!r.ok || len > r.left()) return fail(ErrorCode::CorruptData, "MT: stream length out of range");
        x = Reader{r.p, r.p + len};
        r.p += len;
    }
    if (r.left() != 0) return fail(ErrorCode::CorruptData, "MT: trailing bytes in the payload");
    if (st[0].left() != 16 * nbase) return fail(ErrorCode::CorruptData, "MT: base stream size");
    std::vector<std::array<uint32_t, 4>> base(nbase);
    std::vector<uint8_t> is_base(n, 0);
    for (auto& t : base)
        for (auto& v : t) {
            v = uint32_t(st[0].le(4));
            if (v >= n) return fail(ErrorCode::CorruptData, "MT: base vertex out of range");
            is_base[v] = 1;
        }
    uint64_t nonbase = 0;
    for (uint8_t b : is_base) nonbase += !b;
    if (nonbase != nupd) return fail(ErrorCode::CorruptData, "MT: update count differs from removed points");
    const int errors_at = version == 1 ? 3 : version == 2 ? 4 : 5;
    if (version == 1 ? st[3].left() != 2 * nupd : (st[errors_at].left() != nupd || st[errors_at + 1].left() != nupd))
        return fail(ErrorCode::CorruptData, "MT: error stream size");
    if (version != 1 && st[1].left() != nupd) return fail(ErrorCode::CorruptData, "MT: offset stream size");
    UpdateStreams in = UpdateStreams::of(version, st);
    const uint32_t max_code = max_error_code(int(mb));
    // Coding 3: labels (a low byte and a varint each, in raster order) first,
    // then the error codes, listed in label order, put back in raster order.
    std::vector<uint32_t> labels3;
    std::vector<uint16_t> codes3;
    if (version == 3) {
        if (st[3].left() != nupd) return fail(ErrorCode::CorruptData, "MT: label stream size");
        labels3.resize(nupd);  // nupd bytes are there (checked above)
        for (auto& l : labels3) {
            const uint64_t lo = st[3].le(1), hi = st[4].varint();
            if (!st[4].ok || hi >= (uint64_t(1) << 24) || (lo | hi) == 0)
                return fail(ErrorCode::CorruptData, "MT: bad label");
            l = uint32_t(lo | (hi << 8));
        }
        codes3.resize(nupd);
        for (uint32_t i : label_order(labels3)) {
            const uint64_t code = (st[5].le(1) << 8) | st[6].le(1);
            if (code > max_code) return fail(ErrorCode::CorruptData, "MT: error code out of range");
            codes3[i] = uint16_t(code);
        }
    }
    const mt::Grid g(D);
    std::vector<MtUpdate> ups;
    ups.reserve(nupd);
    std::vector<uint64_t> bits;
    uint64_t nbits = 0;
    for (uint32_t w = 0; w < n; ++w) {
        if (is_base[w]) continue;
        MtUpdate u;
        u.w = w;
        const mt::Pt pw = g.coord(w);
        int64_t c[3];
        if (!in.offset(c)) return fail(ErrorCode::CorruptData, "MT: bad survivor offset");
        for (int a = 0; a < 3; ++a) c[a] += pw[a];
        if (c[0] < 0 || c[1] < 0 || c[2] < 0 || c[0] >= D.x || c[1] >= D.y || c[2] >= D.z)
            return fail(ErrorCode::CorruptData, "MT: survivor outside the grid");
        u.s = g.index(c[0], c[1], c[2]);
        const size_t k = ups.size();
        const uint64_t label = version == 3 ? labels3[k] : in.labels->varint();
        if (version != 3 && (!in.labels->ok || label == 0 || label > 0xFFFFFFFFu))
            return fail(ErrorCode::CorruptData, "MT: bad label");
        u.label = uint32_t(label);
        const uint64_t code = version == 3 ? codes3[k] : in.error_code();
        if (code > max_code) return fail(ErrorCode::CorruptData, "MT: error code out of range");
        u.error = dequantize_error(uint16_t(code), int(mb));
        const uint64_t d = in.stars->varint();
        if (!in.stars->ok || d == 0 || d > 8 * n) return fail(ErrorCode::CorruptData, "MT: bad star size");
        u.star = uint32_t(d);
        // A valid model's stars sum to ~25 n; refuse pools beyond 64 n bits (8 n bytes).
        if (nbits + d > 64 * n + 4096) return fail(ErrorCode::TooLarge, "MT: masks too large");
        const uint64_t cut = in.cuts->varint(), exc = in.counts->varint();
        if (!in.cuts->ok || !in.counts->ok || cut > d || exc > d)
            return fail(ErrorCode::CorruptData, "MT: bad mask header");
        while (bits.size() * 64 < nbits + d) bits.push_back(0);
        for (uint64_t i = 0; i < cut; ++i) bits[(nbits + i) >> 6] |= uint64_t(1) << ((nbits + i) & 63);
        uint64_t pos = 0;
        for (uint64_t e = 0; e < exc; ++e) {
            const uint64_t gap = in.gaps->varint();
            if (!in.gaps->ok) return fail(ErrorCode::CorruptData, "MT: bad mask exception");
            if (e == 0 && version != 1) {
                // Coding 2: the first exception relative to the cut, signed.
                if (gap >= (uint64_t(1) << 40)) return fail(ErrorCode::CorruptData, "MT: bad mask exception");
                const int64_t at = int64_t(cut) + unzigzag(gap);  // no overflow: both below 2^40
                if (at < 0 || uint64_t(at) >= d) return fail(ErrorCode::CorruptData, "MT: bad mask exception");
                pos = uint64_t(at);
            } else {
                if ((e > 0 && gap == 0) || gap >= d || pos + gap >= d)
                    return fail(ErrorCode::CorruptData, "MT: bad mask exception");
                pos += gap;
            }
            bits[(nbits + pos) >> 6] ^= uint64_t(1) << ((nbits + pos) & 63);
        }
        nbits += d;
        ups.push_back(u);
    }
    const int field_stream = nstreams - 1;
    for (int i = 1; i < field_stream; ++i)
        if (st[i].left() != 0) return fail(ErrorCode::CorruptData, "MT: trailing bytes in a stream");
    Reader& field_in = st[field_stream];
    Volume vol;
    if (flags & 1) {
        if (field_in.left() != field_bytes) return fail(ErrorCode::CorruptData, "MT: field stream size");
        vol = Volume::allocate(D, vt);
        std::memcpy(vol.data.data(), field_in.p, field_bytes);
    } else {
        if (field_in.left() != 0) return fail(ErrorCode::CorruptData, "MT: unexpected field stream");
        if (!field) return fail(ErrorCode::NotFound, "MT: field not included and not supplied");
        if (!(field->dims == D) || field->type != vt)
            return fail(ErrorCode::CorruptData, "MT: supplied field does not match the header");
        vol = *field;
    }
    return capture([&] { return MtModel::from_parts(std::move(vol), std::move(base), std::move(ups), std::move(bits)); });
}

}  // namespace tetlod
