#pragma once
// The .tlod container framing (spec/tlod-format.md): a fixed header, a section
// table, and sections that are each one independent zstd frame (or stored bytes)
// with an XXH64 checksum. This layer knows nothing of HT or MT: it moves typed
// byte blobs in and out, enforces the structural rules and the checksums, and
// counts the bytes it reads so callers can measure partial (lazy) reads.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/spill_file.hpp"

namespace tetlod::tlod {

// ---- versions (one named constant per bump; see the spec's "Version changes") ----
inline constexpr uint16_t kVersion1_0_Major = 1;
inline constexpr uint16_t kVersion1_0_Minor = 0;
/// 2.0: HT residual coding 2 (adaptive binary range coder, class-ordered chunks).
inline constexpr uint16_t kVersion2_0_Major = 2;
inline constexpr uint16_t kVersion2_0_Minor = 0;
/// 2.1: the MT model (feature bit 1, MT_HEADER and MT_STRUCTURE sections).
inline constexpr uint16_t kVersion2_1_Major = 2;
inline constexpr uint16_t kVersion2_1_Minor = 1;
/// 3.0: HT residual coding 3, a mode per HT chunk section (table Flags bits 8-11:
/// range, constant, samples, zero-residual). Older readers must refuse it.
inline constexpr uint16_t kVersion3_0_Major = 3;
inline constexpr uint16_t kVersion3_0_Minor = 0;
/// 3.1: error-bounded lossy HT field (required feature bit 2, METADATA key
/// field.max_error). Written only by files that use it: lossless files stay 3.0.
inline constexpr uint16_t kVersion3_1_Minor = 1;
/// 3.2: the compact section table (required feature bit 3, spec §4.4), the
/// default of every writer. Files written with the full table stay 3.0/3.1
/// unless they use a later feature (chunk modes 4 and 5, LOSSY_MT; a full
/// table with chunk mode 6 is refused by the writers).
inline constexpr uint16_t kVersion3_2_Minor = 2;
/// 3.3: HT chunk mode 4, lattice (spec §6.4), in lossy files. Written only by
/// files with such a chunk: a 3.2 reader refuses it (unknown chunk mode).
inline constexpr uint16_t kVersion3_3_Minor = 3;
/// The first chunk mode (table Flags bits 8-11) of 3.3: a file with a section
/// of this mode or above says 3.3.
inline constexpr uint32_t kFirstChunkModeOf3_3 = 4;
/// 3.5: an MT in a lossy file (required feature bit 4, LOSSY_MT). Written only
/// by such files.
inline constexpr uint16_t kVersion3_5_Minor = 5;
/// 3.6: HT chunk mode 5, range-2d (spec §6.4, §7.6), field chunks of any file.
/// Written only by files with such a chunk: a 3.5 reader refuses it (unknown
/// chunk mode).
inline constexpr uint16_t kVersion3_6_Minor = 6;
/// The first chunk mode of 3.6.
inline constexpr uint32_t kFirstChunkModeOf3_6 = 5;
/// 3.7: HT chunk mode 6, static (spec §6.4, §7.6), field chunks of any file.
/// Written only by files with such a chunk (a writer asked for fast decoding):
/// a 3.6 reader refuses it (unknown chunk mode).
inline constexpr uint16_t kVersion3_7_Minor = 7;
/// The first chunk mode of 3.7.
inline constexpr uint32_t kFirstChunkModeOf3_7 = 6;
/// 3.8: HT chunk mode 7, range-exp (spec §6.4, §8.4), error chunks of any file.
/// Written by default (with the compact table): a 3.7 reader refuses such a
/// file (unknown chunk mode).
inline constexpr uint16_t kVersion3_8_Minor = 8;
/// The first chunk mode of 3.8.
inline constexpr uint32_t kFirstChunkModeOf3_8 = 7;
inline constexpr uint16_t kVersionMajor = kVersion3_0_Major;  // what this library writes
inline constexpr uint16_t kVersionMinor = kVersion3_0_Minor;  // (3.1 when a file is lossy)
/// Oldest major version this library still reads (1.x files decode unchanged).
inline constexpr uint16_t kOldestReadableMajor = kVersion1_0_Major;
/// "tlod-format 2.0": for --version output.
const char* format_version_string();

inline constexpr unsigned char kMagic[8] = {0x89, 'T', 'L', 'O', 'D', 0x0D, 0x0A, 0x1A};
inline constexpr uint32_t kHeaderSize = 64;
inline constexpr uint32_t kTableEntrySize = 48;

// ---- feature flags (header) ----
/// Required: the file holds a Hierarchy of Tetrahedra (HT_HEADER + HT_FIELD + HT_ERRORS).
inline constexpr uint64_t kFeatureHt = uint64_t{1} << 0;
/// The file holds an edge-collapse Multi-Tessellation (MT_HEADER + MT_STRUCTURE).
/// Required when the file holds no HT; optional (skippable) next to an HT.
inline constexpr uint64_t kFeatureMt = uint64_t{1} << 1;
/// Required (3.1): the HT field is lossy, every sample within the METADATA key
/// field.max_error of the original, and every error bound is stated against
/// the original (stored code + that bound). Required so that a 3.0 reader
/// refuses the file instead of calling the stored field the original.
inline constexpr uint64_t kFeatureLossy = uint64_t{1} << 2;
/// Required (3.2): the section table is the compact one (spec §4.4), not
/// Section_Count fixed 48-byte entries. Required so that a 3.0/3.1 reader
/// refuses the file instead of reading the compact table as entries.
inline constexpr uint64_t kFeatureCompactTable = uint64_t{1} << 3;
/// Required (3.5): a LOSSY file also holds an MT (next to its HT), built on the
/// stored field, whose update errors include E (spec §5.1): set exactly when
/// LOSSY and the MT are, so that a 3.1-3.4 reader, which knows lossy files only
/// without an MT, refuses the file as needing a newer reader.
inline constexpr uint64_t kFeatureLossyMt = uint64_t{1} << 4;
inline constexpr uint64_t kKnownRequiredFeatures =
    kFeatureHt | kFeatureMt | kFeatureLossy | kFeatureCompactTable | kFeatureLossyMt;

/// How a writer lays out the section table: compact (format 3.2, spec §4.4:
/// one zstd frame of varint columns, offsets implicit) or full (48-byte
/// entries, readable by 3.0/3.1 readers).
enum class TableLayout { compact, full };
/// "compact" / "full".
const char* table_layout_name(TableLayout layout);

// ---- section types ----
enum SectionType : uint32_t {
    kSectionMetadata = 1,
    kSectionHtHeader = 2,
    kSectionHtField = 3,
    kSectionHtErrors = 4,
    kSectionMtHeader = 5,
    kSectionMtStructure = 6,
};
/// Whether this library knows the section type (unknown, non-critical ones are skipped).
bool is_known_section_type(uint32_t type);
const char* section_type_name(uint32_t type);

// ---- section flags ----
inline constexpr uint32_t kSectionZstd = 1u << 0;      // stored bytes are one zstd frame
inline constexpr uint32_t kSectionCritical = 1u << 1;  // readers must understand the type
inline constexpr uint32_t kKnownSectionFlags = kSectionZstd | kSectionCritical;
/// Since 3.0, HT_FIELD and HT_ERRORS sections carry their chunk mode in Flags
/// bits 8-11 (spec §6.4): in the table, so a reader checks a chunk's sizes
/// against its mode before reading it and `info` lists modes without reading.
inline constexpr uint32_t kSectionModeShift = 8;
inline constexpr uint32_t kSectionModeMask = 0xFu << kSectionModeShift;
inline uint32_t section_mode(uint32_t flags) { return (flags & kSectionModeMask) >> kSectionModeShift; }

struct Header {
    uint16_t version_major = kVersionMajor;
    uint16_t version_minor = kVersionMinor;
    uint64_t required_features = 0;
    uint64_t optional_features = 0;
    uint64_t file_size = 0;
    uint32_t section_count = 0;
};

struct SectionInfo {
    uint32_t type = 0;
    uint32_t flags = 0;
    uint64_t offset = 0;
    uint64_t stored_size = 0;
    uint64_t raw_size = 0;
    uint32_t arg0 = 0;  // type-specific (HT chunks: cycle)
    uint32_t arg1 = 0;  // type-specific (HT chunks: brick index)
    uint64_t checksum = 0;  // XXH64(stored bytes, seed 0)
};

/// XXH64 with seed 0 (the container's only checksum).
uint64_t checksum64(std::span<const std::byte> bytes);

/// XXH64 (seed 0) of a whole file, streamed (provenance checksums).
Expected<uint64_t> checksum64_file(const std::string& path);

/// Compresses `raw` as one zstd frame (content size recorded, no dictionary).
/// Throws tetlod::Error only on internal zstd failure.
std::vector<std::byte> zstd_compress(std::span<const std::byte> raw, int level);
/// Decompresses one zstd frame that must expand to exactly `raw_size` bytes.
/// Safe on untrusted input: never allocates more than raw_size (which the
/// caller has validated) and rejects trailing bytes after the frame.
Expected<std::vector<std::byte>> zstd_decompress(std::span<const std::byte> stored,
                                                 uint64_t raw_size);

// ---- reading ----

/// Random-access byte source of a container (a file via pread, or memory).
class ByteSource {
public:
    virtual ~ByteSource() = default;
    virtual uint64_t size() const = 0;
    /// Reads exactly `size` bytes at `offset` into `out`; false on I/O error.
    virtual bool read_at(uint64_t offset, std::byte* out, std::size_t size) = 0;
};

class ContainerReader {
public:
    /// Opens a file and validates the header and the section table (only those
    /// bytes are read). Safe on untrusted input.
    static Expected<ContainerReader> open(const std::string& path);
    /// Same over a memory buffer, which must outlive the reader (fuzzers, tests).
    static Expected<ContainerReader> from_memory(std::span<const std::byte> bytes,
                                                 std::string name = "<memory>");

    const Header& header() const { return header_; }
    const std::vector<SectionInfo>& sections() const { return sections_; }
    const std::string& name() const { return name_; }

    /// Index of the first section of `type` (with arg0/arg1 when given), or -1.
    int find(uint32_t type) const;

    /// Reads section i's stored bytes, checks the checksum, decompresses and
    /// checks the raw size. Safe on untrusted input.
    Expected<std::vector<std::byte>> read_section(std::size_t i);
    /// Reads the stored bytes and checks only the checksum (verify).
    Expected<std::vector<std::byte>> read_stored(std::size_t i);

    /// Bytes read from the source so far (header and table included), a
    /// section read twice counted twice.
    uint64_t bytes_read() const { return bytes_read_; }
    /// The file's bytes read so far, each counted once: header, table and the
    /// sections read at least once (what part of the file a query touched).
    uint64_t distinct_bytes_read() const { return distinct_bytes_read_; }
    /// The layout of the file's section table and its size in bytes (what
    /// follows the 64-byte header up to the first section).
    TableLayout table_layout() const {
        return (header_.required_features & kFeatureCompactTable) ? TableLayout::compact : TableLayout::full;
    }
    uint64_t table_bytes() const { return table_bytes_; }

private:
    static Expected<ContainerReader> parse(std::unique_ptr<ByteSource> src, std::string name);
    std::shared_ptr<ByteSource> src_;
    std::string name_;
    Header header_;
    std::vector<SectionInfo> sections_;
    uint64_t bytes_read_ = 0, distinct_bytes_read_ = 0;
    std::vector<bool> section_read_;  // per section: read at least once
    uint64_t table_bytes_ = 0;
};

// ---- writing ----

/// Collects sections in file order and writes the container atomically.
class ContainerWriter {
public:
    /// The model's features; the table layout adds its own bit (set_table).
    void set_features(uint64_t required, uint64_t optional = 0) {
        header_.required_features = required;
        header_.optional_features = optional;
    }
    uint64_t required_features() const { return header_.required_features; }
    /// The section table's layout (default compact, format 3.2). A file with the
    /// full table says 3.1 when lossy and 3.0 otherwise, byte for byte as before 3.2.
    void set_table(TableLayout layout) {
        table_ = layout;
        table_cached_ = false;
    }
    TableLayout table() const { return table_; }
    /// Appends a section whose stored bytes are already final (e.g. compressed
    /// in parallel by the caller with zstd_compress); flags must say how.
    void add_stored(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1,
                    std::vector<std::byte> stored, uint64_t raw_size);
    /// Appends a section whose stored bytes a streaming encoder wrote to
    /// `spill` at `offset` (sections larger than memory stay on disk until
    /// write() copies them); `spill` must outlive finish() and write().
    void add_spilled(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1, SpillFile& spill,
                     uint64_t offset, uint64_t stored_size, uint64_t raw_size, uint64_t checksum);
    /// Compresses `raw` with zstd at `level` and appends it.
    void add(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1,
             std::span<const std::byte> raw, int level);
    /// Appends a section whose stored bytes someone else writes at its offset
    /// (a distributed writer: each process writes the sections it encoded).
    /// finish() and write() refuse a writer holding such a section.
    void add_external(uint32_t type, uint32_t flags, uint32_t arg0, uint32_t arg1, uint64_t stored_size,
                      uint64_t raw_size, uint64_t checksum);

    /// The sections' offsets in the file, in the order they were added.
    std::vector<uint64_t> section_offsets() const;
    /// The file's first bytes: the header, the table and the stored bytes of
    /// the sections before the first spilled or external one (what a
    /// distributed writer's coordinator writes at offset 0).
    std::vector<std::byte> leading_bytes() const;
    /// The size of the whole file.
    uint64_t file_size() const;

    /// The whole file in memory.
    std::vector<std::byte> finish() const;
    /// Writes the file atomically (temp file + rename). Throws tetlod::Error.
    void write(const std::string& path) const;

private:
    std::vector<std::byte> head_bytes() const;
    /// The table region's bytes, computed once after the last add.
    const std::vector<std::byte>& table_bytes() const;
    uint64_t table_end() const;
    void refuse_external() const;
    Header header_;
    TableLayout table_ = TableLayout::compact;
    // The table's bytes depend on every section: computed once, dropped by each add.
    mutable std::vector<std::byte> table_cache_;
    mutable bool table_cached_ = false;
    std::vector<SectionInfo> sections_;
    struct Payload {
        std::vector<std::byte> bytes;
        SpillFile* spill = nullptr;  // else the bytes are at [offset, offset + stored size) of it
        uint64_t offset = 0;
        bool external = false;  // written by someone else (add_external)
    };
    std::vector<Payload> payloads_;
};

}  // namespace tetlod::tlod
