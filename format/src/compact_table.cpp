// Compact section table (spec §4.4). Columns rather than rows: each column
// (types, flags, arg deltas, sizes) is a run of similar small numbers that zstd
// folds to a few bytes, and the incompressible checksums sit together at the
// end instead of breaking every match.
#include "compact_table.hpp"

#include <zstd.h>

#include "tetlod/core/varint.hpp"
#include "tetlod/format/byte_io.hpp"

namespace tetlod::tlod::compact_table {

namespace {

// Arguments are delta-coded against the previous entry's (chunk cycles and
// bricks mostly repeat or step by one), wrapping modulo 2^32, and the signed
// difference zigzag-coded so a step back is as small as a step forward.
uint32_t zigzag_delta(uint32_t value, uint32_t previous) {
    const uint32_t d = value - previous;
    return (d << 1) ^ (0u - (d >> 31));
}
uint32_t undo_zigzag_delta(uint32_t zz, uint32_t previous) {
    const uint32_t d = (zz >> 1) ^ (0u - (zz & 1u));
    return previous + d;
}

/// Reads the LEB128 varints of the content; the first bad one latches a message.
class VarintReader {
public:
    explicit VarintReader(std::span<const std::byte> b) : b_(b) {}
    /// A varint of at most `max_bytes` bytes whose value fits `bits`, in its
    /// shortest form (no final 0x00 byte after the first).
    uint64_t read(int bits, const char* field) {
        if (!error_.empty()) return 0;
        const int max_bytes = (bits + 6) / 7;
        uint64_t v = 0;
        for (int i = 0;; ++i) {
            if (pos_ >= b_.size()) return bad(field, "ends inside a varint");
            if (i == max_bytes) return bad(field, "varint longer than its field");
            const uint8_t byte = std::to_integer<uint8_t>(b_[pos_++]);
            const uint64_t part = uint64_t(byte & 0x7f);
            if (7 * i + 7 > bits && (part >> (bits - 7 * i)) != 0) return bad(field, "varint overflows its field");
            v |= part << (7 * i);
            if (!(byte & 0x80)) {
                if (byte == 0 && i > 0) return bad(field, "varint not in its shortest form");
                return v;
            }
        }
    }
    uint64_t fixed64() {
        if (!error_.empty()) return 0;
        if (b_.size() - pos_ < 8) return bad("checksum", "ends inside a checksum");
        const uint64_t v = load_le(b_.data() + pos_, 8);
        pos_ += 8;
        return v;
    }
    bool at_end() const { return pos_ == b_.size(); }
    const std::string& error() const { return error_; }
    std::size_t entry = 0;  // the entry being read, for messages

private:
    uint64_t bad(const char* field, const char* what) {
        error_ = std::string("compact section table: ") + what + " (" + field + " of entry " +
                 std::to_string(entry) + ")";
        return 0;
    }
    std::span<const std::byte> b_;
    std::size_t pos_ = 0;
    std::string error_;
};

}  // namespace

std::vector<std::byte> encode(std::span<const SectionInfo> sections) {
    std::vector<std::byte> content;
    uint32_t prev0 = 0, prev1 = 0;
    for (const SectionInfo& s : sections) put_varint(content, s.type);
    for (const SectionInfo& s : sections) put_varint(content, s.flags);
    for (const SectionInfo& s : sections) {
        put_varint(content, zigzag_delta(s.arg0, prev0));
        prev0 = s.arg0;
    }
    for (const SectionInfo& s : sections) {
        put_varint(content, zigzag_delta(s.arg1, prev1));
        prev1 = s.arg1;
    }
    for (const SectionInfo& s : sections) put_varint(content, s.stored_size);
    // Stored bytes are the raw bytes unless they are a zstd frame.
    for (const SectionInfo& s : sections)
        if (s.flags & kSectionZstd) put_varint(content, s.raw_size);
    // An empty section has nothing to corrupt: its checksum would be a constant.
    for (const SectionInfo& s : sections)
        if (s.stored_size > 0) put_u64(content, s.checksum);
    const std::vector<std::byte> frame = zstd_compress(content, kZstdLevel);
    std::vector<std::byte> region;
    region.reserve(kFrameSizeBytes + frame.size());
    put_u32(region, static_cast<uint32_t>(frame.size()));
    region.insert(region.end(), frame.begin(), frame.end());
    return region;
}

Expected<std::vector<SectionInfo>> decode(std::span<const std::byte> frame, uint32_t section_count) {
    const unsigned long long declared = ZSTD_getFrameContentSize(frame.data(), frame.size());
    if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN)
        return fail(ErrorCode::CorruptData, "compact section table: not a zstd frame with a content size");
    // Bounded before anything is allocated: no honest table of n entries is longer.
    if (declared > kMaxEntryBytes * section_count)
        return fail(ErrorCode::CorruptData, "compact section table: " + std::to_string(declared) +
                                                " bytes of entries for " + std::to_string(section_count) +
                                                " sections (at most " + std::to_string(kMaxEntryBytes) +
                                                " each)");
    // Every entry takes at least 5 bytes (type, flags, two arg deltas, stored
    // size): this bounds the entries allocated below by the content's size.
    if (declared < 5 * uint64_t{section_count})
        return fail(ErrorCode::CorruptData, "compact section table: " + std::to_string(declared) +
                                                " bytes cannot hold " + std::to_string(section_count) +
                                                " entries (at least 5 bytes each)");
    auto content = zstd_decompress(frame, declared);
    if (!content) return with_context("compact section table: ", content.failure());

    std::vector<SectionInfo> out(section_count);
    VarintReader r(*content);
    uint32_t prev0 = 0, prev1 = 0;
    for (r.entry = 0; r.entry < out.size(); ++r.entry) out[r.entry].type = uint32_t(r.read(32, "type"));
    for (r.entry = 0; r.entry < out.size(); ++r.entry) out[r.entry].flags = uint32_t(r.read(32, "flags"));
    for (r.entry = 0; r.entry < out.size(); ++r.entry)
        prev0 = out[r.entry].arg0 = undo_zigzag_delta(uint32_t(r.read(32, "arg0")), prev0);
    for (r.entry = 0; r.entry < out.size(); ++r.entry)
        prev1 = out[r.entry].arg1 = undo_zigzag_delta(uint32_t(r.read(32, "arg1")), prev1);
    for (r.entry = 0; r.entry < out.size(); ++r.entry) out[r.entry].stored_size = r.read(64, "stored size");
    for (r.entry = 0; r.entry < out.size(); ++r.entry) {
        SectionInfo& s = out[r.entry];
        s.raw_size = (s.flags & kSectionZstd) ? r.read(64, "raw size") : s.stored_size;
    }
    const uint64_t empty_checksum = checksum64({});
    for (r.entry = 0; r.entry < out.size(); ++r.entry) {
        SectionInfo& s = out[r.entry];
        s.checksum = s.stored_size > 0 ? r.fixed64() : empty_checksum;
    }
    if (!r.error().empty()) return fail(ErrorCode::CorruptData, r.error());
    if (!r.at_end()) return fail(ErrorCode::CorruptData, "compact section table: bytes after the last entry");
    return out;
}

}  // namespace tetlod::tlod::compact_table
