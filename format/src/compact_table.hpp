#pragma once
// The compact section table of format 3.2 (spec/tlod-format.md §4.4): the
// entries as varint columns in one zstd frame, offsets implicit. Private to
// the container: ContainerReader/ContainerWriter are its only clients.
#include <cstdint>
#include <span>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/format/container.hpp"

namespace tetlod::tlod::compact_table {

/// The longest an entry can be once decompressed (spec §4.4: 5 + 5 + 5 + 5 +
/// 10 + 10 + 8 bytes), so a table of n entries never expands past 48 n.
inline constexpr uint64_t kMaxEntryBytes = 48;
/// Bytes of the Table_Frame_Size field that precedes the frame.
inline constexpr uint32_t kFrameSizeBytes = 4;
/// zstd level of the table frame: fixed, so that every writer (serial,
/// streaming, distributed) writes the same bytes for the same sections.
inline constexpr int kZstdLevel = 19;

/// The table region (Table_Frame_Size, then the frame) describing `sections`
/// in order; their offsets are ignored (they are implicit).
std::vector<std::byte> encode(std::span<const SectionInfo> sections);

/// The entries of a table frame (untrusted; the caller has checked its size
/// against the file and its checksum): type, flags, args, sizes and checksums
/// (an empty section gets XXH64 of no bytes); offsets are left 0 for the
/// caller's prefix sum and its §4.2 checks. CorruptData for a frame that is
/// not one zstd frame with its content size, content larger than
/// kMaxEntryBytes per entry, a bad varint, or bytes left after the entries.
Expected<std::vector<SectionInfo>> decode(std::span<const std::byte> frame, uint32_t section_count);

}  // namespace tetlod::tlod::compact_table
