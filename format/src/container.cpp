// Header and section table of the .tlod container: reading with every structural
// rule of spec/tlod-format.md §3-§4 checked before anything is trusted, and writing.
#include "tetlod/format/container.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/regular_file.hpp"
#include "tetlod/format/byte_io.hpp"
#include "compact_table.hpp"

namespace tetlod::tlod {

namespace {
// Fuzzing builds (the libFuzzer convention) accept wrong checksums so that the
// fuzzer's mutations reach the decoders behind them; never in a real build.
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
constexpr bool kCheckChecksums = false;
#else
constexpr bool kCheckChecksums = true;
#endif
}  // namespace

const char* table_layout_name(TableLayout layout) {
    return layout == TableLayout::compact ? "compact" : "full";
}

bool is_known_section_type(uint32_t type) {
    return type >= kSectionMetadata && type <= kSectionMtStructure;
}

const char* section_type_name(uint32_t type) {
    switch (type) {
        case kSectionMetadata: return "METADATA";
        case kSectionHtHeader: return "HT_HEADER";
        case kSectionHtField: return "HT_FIELD";
        case kSectionHtErrors: return "HT_ERRORS";
        case kSectionMtHeader: return "MT_HEADER";
        case kSectionMtStructure: return "MT_STRUCTURE";
    }
    return "UNKNOWN";
}

namespace {

class FileSource final : public ByteSource {
public:
    FileSource(int fd, uint64_t size) : fd_(fd), size_(size) {}
    ~FileSource() override { ::close(fd_); }
    uint64_t size() const override { return size_; }
    bool read_at(uint64_t offset, std::byte* out, std::size_t n) override {
        while (n > 0) {
            ssize_t r = ::pread(fd_, out, n, static_cast<off_t>(offset));
            if (r < 0 && errno == EINTR) continue;
            if (r <= 0) return false;
            out += r;
            n -= static_cast<std::size_t>(r);
            offset += static_cast<uint64_t>(r);
        }
        return true;
    }

private:
    int fd_;
    uint64_t size_;
};

class MemorySource final : public ByteSource {
public:
    explicit MemorySource(std::span<const std::byte> b) : b_(b) {}
    uint64_t size() const override { return b_.size(); }
    bool read_at(uint64_t offset, std::byte* out, std::size_t n) override {
        if (offset > b_.size() || n > b_.size() - offset) return false;
        if (n) std::memcpy(out, b_.data() + offset, n);
        return true;
    }

private:
    std::span<const std::byte> b_;
};

// A valid zstd frame expands at most 32768x (a 4-byte RLE block per 128 KiB);
// a larger claimed raw size cannot be honest, so it is refused before allocating.
bool plausible_raw_size(const SectionInfo& s) {
    if (!(s.flags & kSectionZstd)) return s.raw_size == s.stored_size;
    if (s.stored_size > (uint64_t{1} << 47)) return true;
    return s.raw_size <= s.stored_size * 32768 + 131072;
}

struct TableEntries {
    std::vector<SectionInfo> entries;  // in file order
    uint64_t end = 0;                  // where the first section starts
};

// Spec §4.2: Section_Count entries of 48 bytes after the header.
Expected<TableEntries> read_full_table(ByteSource& src, const Header& h, uint64_t table_checksum,
                                       const std::string& where) {
    const uint64_t table_end = uint64_t{kHeaderSize} + uint64_t{h.section_count} * kTableEntrySize;
    if (table_end > h.file_size)
        return fail(ErrorCode::CorruptData, where + "the section table (" +
                                                std::to_string(h.section_count) +
                                                " entries) extends past the end of the file");
    std::vector<std::byte> table(static_cast<std::size_t>(table_end - kHeaderSize));
    if (!src.read_at(kHeaderSize, table.data(), table.size())) return fail(ErrorCode::IoError, where + "read failed");
    if (kCheckChecksums && checksum64(table) != table_checksum)
        return fail(ErrorCode::ChecksumMismatch, where + "section table checksum mismatch");
    TableEntries out;
    out.end = table_end;
    out.entries.resize(h.section_count);
    ByteReader t(table);
    for (SectionInfo& s : out.entries) {
        s.type = t.u32();
        s.flags = t.u32();
        s.offset = t.u64();
        s.stored_size = t.u64();
        s.raw_size = t.u64();
        s.arg0 = t.u32();
        s.arg1 = t.u32();
        s.checksum = t.u64();
    }
    return out;
}

// Spec §4.4: Table_Frame_Size, then one zstd frame of the entries. Every size
// is checked against the file before the frame is read or decompressed.
Expected<TableEntries> read_compact_table(ByteSource& src, const Header& h, uint64_t table_checksum,
                                          const std::string& where) {
    if (h.version_major != kVersion3_0_Major)
        return fail(ErrorCode::CorruptData, where + "a compact section table in a file of major version " +
                                                std::to_string(h.version_major));
    // No valid file describes more sections than it has bytes (an empty
    // section still costs its entry): refused before anything is decompressed.
    if (h.section_count > h.file_size)
        return fail(ErrorCode::CorruptData, where + std::to_string(h.section_count) +
                                                " sections claimed by a file of " + std::to_string(h.file_size) +
                                                " bytes");
    const uint64_t frame_at = uint64_t{kHeaderSize} + compact_table::kFrameSizeBytes;
    if (frame_at > h.file_size)
        return fail(ErrorCode::CorruptData, where + "the section table extends past the end of the file");
    std::vector<std::byte> region(compact_table::kFrameSizeBytes);
    if (!src.read_at(kHeaderSize, region.data(), region.size())) return fail(ErrorCode::IoError, where + "read failed");
    const uint64_t frame_size = load_le(region.data(), 4);
    if (frame_size > h.file_size - frame_at)
        return fail(ErrorCode::CorruptData, where + "the compact section table (" + std::to_string(frame_size) +
                                                " bytes) extends past the end of the file");
    region.resize(static_cast<std::size_t>(compact_table::kFrameSizeBytes + frame_size));
    if (!src.read_at(frame_at, region.data() + compact_table::kFrameSizeBytes, static_cast<std::size_t>(frame_size)))
        return fail(ErrorCode::IoError, where + "read failed");
    if (kCheckChecksums && checksum64(region) != table_checksum)
        return fail(ErrorCode::ChecksumMismatch, where + "section table checksum mismatch");
    auto entries = compact_table::decode(std::span<const std::byte>(region).subspan(compact_table::kFrameSizeBytes),
                                         h.section_count);
    if (!entries) return with_context(where, entries.failure());
    TableEntries out;
    out.entries = std::move(*entries);
    out.end = frame_at + frame_size;
    return out;
}

}  // namespace

Expected<ContainerReader> ContainerReader::open(const std::string& path) {
    if (auto bad = regular_file_failure(path, "container")) return *bad;
    int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return fail(ErrorCode::IoError, "cannot open '" + path + "': " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd);
        return fail(ErrorCode::IoError, "'" + path + "' is not a regular file");
    }
    return parse(std::make_unique<FileSource>(fd, static_cast<uint64_t>(st.st_size)), path);
}

Expected<ContainerReader> ContainerReader::from_memory(std::span<const std::byte> bytes,
                                                       std::string name) {
    return parse(std::make_unique<MemorySource>(bytes), std::move(name));
}

Expected<ContainerReader> ContainerReader::parse(std::unique_ptr<ByteSource> src, std::string name) {
    const std::string where = name + ": ";
    const uint64_t size = src->size();
    std::byte head[kHeaderSize];
    const std::size_t got = static_cast<std::size_t>(std::min<uint64_t>(size, kHeaderSize));
    if (!src->read_at(0, head, got)) return fail(ErrorCode::IoError, where + "read failed");
    const std::size_t magic_part = std::min<std::size_t>(got, 8);
    if (std::memcmp(head, kMagic, magic_part) != 0)
        return fail(ErrorCode::BadMagic, where + "not a .tlod container (bad magic)");
    if (got < kHeaderSize)
        return fail(ErrorCode::Truncated, where + "truncated: the file ends inside the " +
                                              std::to_string(kHeaderSize) + "-byte header (" +
                                              std::to_string(size) + " bytes)");
    ByteReader r(std::span<const std::byte>(head, kHeaderSize));
    r.str(8);
    Header h;
    h.version_major = r.u16();
    h.version_minor = r.u16();
    const uint32_t header_size = r.u32();
    h.required_features = r.u64();
    h.optional_features = r.u64();
    h.file_size = r.u64();
    h.section_count = r.u32();
    const uint32_t entry_size = r.u32();
    const uint64_t table_checksum = r.u64();
    const uint64_t header_checksum = r.u64();
    if (kCheckChecksums && checksum64(std::span<const std::byte>(head, 56)) != header_checksum)
        return fail(ErrorCode::ChecksumMismatch, where + "header checksum mismatch");
    if (h.version_major < kOldestReadableMajor || h.version_major > kVersionMajor)
        return fail(ErrorCode::UnsupportedVersion,
                    where + "format version " + std::to_string(h.version_major) + "." +
                        std::to_string(h.version_minor) + " is not supported (this reader: " +
                        std::to_string(kOldestReadableMajor) + ".x to " +
                        std::to_string(kVersionMajor) + ".x)");
    if (header_size != kHeaderSize || entry_size != kTableEntrySize)
        return fail(ErrorCode::CorruptData, where + "header or table entry size is not the one of version 1");
    if (uint64_t unknown = h.required_features & ~kKnownRequiredFeatures)
        return fail(ErrorCode::UnsupportedFeature,
                    where + "requires unknown features (bits 0x" + [&] {
                        char b[32];
                        std::snprintf(b, sizeof b, "%llx", static_cast<unsigned long long>(unknown));
                        return std::string(b);
                    }() + "); a newer reader is needed");
    // Spec §4.1: the lossy field of 3.1 belongs to an HT; an MT beside it (3.5)
    // states its errors against the original, which LOSSY_MT says.
    {
        const bool lossy = (h.required_features & kFeatureLossy) != 0;
        const bool mt = ((h.required_features | h.optional_features) & kFeatureMt) != 0;
        const bool lossy_mt = (h.required_features & kFeatureLossyMt) != 0;
        if (lossy && !(h.required_features & kFeatureHt))
            return fail(ErrorCode::CorruptData, where + "the LOSSY feature needs an HT");
        if (lossy_mt != (lossy && mt))
            return fail(ErrorCode::CorruptData,
                        where + "the LOSSY_MT feature must be set exactly when LOSSY and the MT are");
    }
    if (size < h.file_size)
        return fail(ErrorCode::Truncated, where + "truncated: " + std::to_string(size) +
                                              " bytes, the header declares " +
                                              std::to_string(h.file_size));
    if (size > h.file_size)
        return fail(ErrorCode::CorruptData, where + std::to_string(size - h.file_size) +
                                                " trailing bytes after the declared end of the file");
    auto table = (h.required_features & kFeatureCompactTable)
                     ? read_compact_table(*src, h, table_checksum, where)
                     : read_full_table(*src, h, table_checksum, where);
    if (!table) return table.failure();
    const uint64_t table_end = table->end;

    ContainerReader out;
    out.sections_.reserve(h.section_count);
    uint64_t expected_offset = table_end;
    for (uint32_t i = 0; i < h.section_count; ++i) {
        SectionInfo s = table->entries[i];
        // The compact table has no offsets: each section starts where the previous ends.
        if (h.required_features & kFeatureCompactTable) s.offset = expected_offset;
        const std::string sec = where + "section " + std::to_string(i) + " (" +
                                section_type_name(s.type) + "): ";
        // The chunk-mode bits exist only on HT chunk sections of 3.0 files;
        // whether the mode fits the HT's coding is the HT layout's business.
        const bool mode_bits_allowed = h.version_major >= kVersion3_0_Major &&
                                       (s.type == kSectionHtField || s.type == kSectionHtErrors);
        if (s.flags & ~(kKnownSectionFlags | (mode_bits_allowed ? kSectionModeMask : 0u)))
            return fail(ErrorCode::CorruptData, sec + "reserved flag bits are set");
        if (s.offset != expected_offset)
            return fail(ErrorCode::CorruptData, sec + "offset " + std::to_string(s.offset) +
                                                    " is not the end of the previous section (" +
                                                    std::to_string(expected_offset) + ")");
        if (s.stored_size > h.file_size - s.offset)
            return fail(ErrorCode::CorruptData, sec + "extends past the end of the file");
        if (!plausible_raw_size(s))
            return fail(ErrorCode::CorruptData, sec + "raw size " + std::to_string(s.raw_size) +
                                                    " is impossible for its stored size");
        if (!is_known_section_type(s.type) && (s.flags & kSectionCritical))
            return fail(ErrorCode::UnsupportedFeature,
                        sec + "critical section of unknown type " + std::to_string(s.type));
        expected_offset = s.offset + s.stored_size;
        out.sections_.push_back(s);
    }
    if (expected_offset != h.file_size)
        return fail(ErrorCode::CorruptData, where + "bytes between the last section and the end of the file");
    out.header_ = h;
    out.name_ = std::move(name);
    out.src_ = std::move(src);
    out.bytes_read_ = out.distinct_bytes_read_ = table_end;
    out.section_read_.assign(out.sections_.size(), false);
    out.table_bytes_ = table_end - kHeaderSize;
    return out;
}

int ContainerReader::find(uint32_t type) const {
    for (std::size_t i = 0; i < sections_.size(); ++i)
        if (sections_[i].type == type) return static_cast<int>(i);
    return -1;
}

Expected<std::vector<std::byte>> ContainerReader::read_stored(std::size_t i) {
    if (i >= sections_.size()) return fail(ErrorCode::NotFound, name_ + ": no section " + std::to_string(i));
    const SectionInfo& s = sections_[i];
    std::vector<std::byte> stored(static_cast<std::size_t>(s.stored_size));
    if (!src_->read_at(s.offset, stored.data(), stored.size()))
        return fail(ErrorCode::IoError, name_ + ": read failed");
    bytes_read_ += s.stored_size;
    if (!section_read_[i]) section_read_[i] = true, distinct_bytes_read_ += s.stored_size;
    if (kCheckChecksums && checksum64(stored) != s.checksum)
        return fail(ErrorCode::ChecksumMismatch, name_ + ": section " + std::to_string(i) + " (" +
                                                     section_type_name(s.type) +
                                                     ") checksum mismatch");
    return stored;
}

Expected<std::vector<std::byte>> ContainerReader::read_section(std::size_t i) {
    auto stored = read_stored(i);
    if (!stored) return stored.failure();
    const SectionInfo& s = sections_[i];
    if (!(s.flags & kSectionZstd)) return stored;
    auto raw = zstd_decompress(*stored, s.raw_size);
    if (!raw)
        return with_context(name_ + ": section " + std::to_string(i) + " (" + section_type_name(s.type) + "): ",
                            raw.failure());
    return raw;
}

// ---- writer ----

void ContainerWriter::add_stored(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1,
                                 std::vector<std::byte> stored, uint64_t raw_size) {
    SectionInfo s;
    s.type = type;
    s.flags = flags;
    s.stored_size = stored.size();
    s.raw_size = raw_size;
    s.arg0 = arg0;
    s.arg1 = arg1;
    s.checksum = checksum64(stored);
    sections_.push_back(s);
    payloads_.push_back(Payload{std::move(stored), nullptr, 0});
    table_cached_ = false;
}

namespace {

/// The table entry of a section whose bytes are stored elsewhere (spill or another writer).
SectionInfo section_entry(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1, uint64_t stored_size,
                          uint64_t raw_size, uint64_t checksum) {
    SectionInfo s;
    s.type = type;
    s.flags = flags;
    s.stored_size = stored_size;
    s.raw_size = raw_size;
    s.arg0 = arg0;
    s.arg1 = arg1;
    s.checksum = checksum;
    return s;
}

}  // namespace

void ContainerWriter::add_spilled(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1, SpillFile& spill,
                                  uint64_t offset, uint64_t stored_size, uint64_t raw_size, uint64_t checksum) {
    sections_.push_back(section_entry(type, flags, arg0, arg1, stored_size, raw_size, checksum));
    payloads_.push_back(Payload{{}, &spill, offset});
    table_cached_ = false;
}

void ContainerWriter::add(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1,
                          std::span<const std::byte> raw, int level) {
    add_stored(type, flags | kSectionZstd, arg0, arg1, zstd_compress(raw, level), raw.size());
}

void ContainerWriter::add_external(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1, uint64_t stored_size,
                                   uint64_t raw_size, uint64_t checksum) {
    sections_.push_back(section_entry(type, flags, arg0, arg1, stored_size, raw_size, checksum));
    Payload p;
    p.external = true;
    payloads_.push_back(std::move(p));
    table_cached_ = false;
}

const std::vector<std::byte>& ContainerWriter::table_bytes() const {
    if (table_cached_) return table_cache_;
    std::vector<std::byte> table;
    if (table_ == TableLayout::compact) {
        table = compact_table::encode(sections_);
    } else {
        uint64_t offset = uint64_t{kHeaderSize} + uint64_t{kTableEntrySize} * sections_.size();
        table.reserve(kTableEntrySize * sections_.size());
        for (const SectionInfo& s : sections_) {
            put_u32(table, s.type);
            put_u32(table, s.flags);
            put_u64(table, offset);
            put_u64(table, s.stored_size);
            put_u64(table, s.raw_size);
            put_u32(table, s.arg0);
            put_u32(table, s.arg1);
            put_u64(table, s.checksum);
            offset += s.stored_size;
        }
    }
    table_cache_ = std::move(table);
    table_cached_ = true;
    return table_cache_;
}

uint64_t ContainerWriter::table_end() const {
    if (table_ == TableLayout::full) return uint64_t{kHeaderSize} + uint64_t{kTableEntrySize} * sections_.size();
    return uint64_t{kHeaderSize} + table_bytes().size();
}

std::vector<uint64_t> ContainerWriter::section_offsets() const {
    std::vector<uint64_t> out;
    out.reserve(sections_.size());
    uint64_t offset = table_end();
    for (const SectionInfo& s : sections_) {
        out.push_back(offset);
        offset += s.stored_size;
    }
    return out;
}

uint64_t ContainerWriter::file_size() const {
    uint64_t offset = table_end();
    for (const SectionInfo& s : sections_) offset += s.stored_size;
    return offset;
}

std::vector<std::byte> ContainerWriter::leading_bytes() const {
    std::vector<std::byte> out = head_bytes();
    for (const Payload& p : payloads_) {
        if (p.spill || p.external) break;
        out.insert(out.end(), p.bytes.begin(), p.bytes.end());
    }
    return out;
}

std::vector<std::byte> ContainerWriter::head_bytes() const {
    const std::vector<std::byte>& table = table_bytes();
    const bool compact = table_ == TableLayout::compact;
    const uint64_t required = header_.required_features | (compact ? kFeatureCompactTable : 0);
    // A file says the oldest version that has every feature it uses: files
    // with the full table and nothing newer stay 3.0 (3.1 when lossy), byte for byte.
    // 3.3 when a section uses a chunk mode of 3.3 (spec §4.1, §6.4).
    // 3.6 when one uses a chunk mode of 3.6 (§7.6), whatever else the file has;
    // 3.7 when one uses a chunk mode of 3.7, 3.8 one of 3.8.
    const bool modes_3_3 = std::any_of(sections_.begin(), sections_.end(), [](const SectionInfo& s) {
        return section_mode(s.flags) >= kFirstChunkModeOf3_3;
    });
    const bool modes_3_6 = std::any_of(sections_.begin(), sections_.end(), [](const SectionInfo& s) {
        return section_mode(s.flags) >= kFirstChunkModeOf3_6;
    });
    const bool modes_3_7 = std::any_of(sections_.begin(), sections_.end(), [](const SectionInfo& s) {
        return section_mode(s.flags) >= kFirstChunkModeOf3_7;
    });
    const bool modes_3_8 = std::any_of(sections_.begin(), sections_.end(), [](const SectionInfo& s) {
        return section_mode(s.flags) >= kFirstChunkModeOf3_8;
    });
    const uint16_t minor = modes_3_8                                ? kVersion3_8_Minor
                           : modes_3_7                              ? kVersion3_7_Minor
                           : modes_3_6                              ? kVersion3_6_Minor
                           : (required & kFeatureLossyMt)           ? kVersion3_5_Minor
                           : modes_3_3                              ? kVersion3_3_Minor
                           : compact                                ? kVersion3_2_Minor
                           : (required & kFeatureLossy)             ? kVersion3_1_Minor
                                                                    : kVersion3_0_Minor;
    std::vector<std::byte> h;
    h.reserve(kHeaderSize + table.size());
    for (unsigned char c : kMagic) put_u8(h, c);
    put_u16(h, kVersion3_0_Major);
    put_u16(h, minor);
    put_u32(h, kHeaderSize);
    put_u64(h, required);
    put_u64(h, header_.optional_features);
    put_u64(h, file_size());
    put_u32(h, static_cast<uint32_t>(sections_.size()));
    // 48 in both layouts: a 3.0/3.1 reader checks it before Required_Features
    // and must get as far as refusing the unknown COMPACT_TABLE bit (spec §4.1).
    put_u32(h, kTableEntrySize);
    put_u64(h, checksum64(table));
    put_u64(h, checksum64(h));
    h.insert(h.end(), table.begin(), table.end());
    return h;
}

std::vector<std::byte> ContainerWriter::finish() const {
    refuse_external();
    std::vector<std::byte> out = head_bytes();
    for (std::size_t i = 0; i < payloads_.size(); ++i) {
        const Payload& p = payloads_[i];
        if (!p.spill) out.insert(out.end(), p.bytes.begin(), p.bytes.end());
        else p.spill->read_range(p.offset, sections_[i].stored_size,
                                 [&](const std::byte* d, std::size_t n) { out.insert(out.end(), d, d + n); });
    }
    return out;
}

void ContainerWriter::refuse_external() const {
    for (const Payload& p : payloads_)
        if (p.external)
            throw Error(ErrorCode::InvalidArgument, "ContainerWriter: a section's bytes are written elsewhere (add_external)");
}

void ContainerWriter::write(const std::string& path) const {
    refuse_external();
    AtomicFile f(path);
    std::vector<std::byte> head = head_bytes();
    f.write(head.data(), head.size());
    for (std::size_t i = 0; i < payloads_.size(); ++i) {
        const Payload& p = payloads_[i];
        if (!p.spill) f.write(p.bytes.data(), p.bytes.size());
        else p.spill->read_range(p.offset, sections_[i].stored_size,
                                 [&](const std::byte* d, std::size_t n) { f.write(d, n); });
    }
    f.commit();
}

}  // namespace tetlod::tlod
