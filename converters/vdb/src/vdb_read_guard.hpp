#pragma once
// Checks that keep hostile .vdb files away from OpenVDB (or from large
// allocations). Own parser, no OpenVDB include, so it runs in the calling
// process before the library sees the file, and libFuzzer sees its coverage.
//  - check_vdb_layout: header (magic, format version), file metadata, grid
//    descriptors (every string length and metadata size within the file, grid
//    offsets ordered and inside the file), each grid's metadata and transform
//    name. OpenVDB allocates (and fills) every string and metadata value at the
//    size the file claims, so one flipped bit there would cost gigabytes.
//  - parse_dims_xyz / check_dense_bound: the dense extent a grid may claim,
//    used both here and by the reader after the library read the grid.
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "tetlod/core/volume.hpp"

namespace tetlod::vdb_guard {

/// A dense volume may hold at most this many bytes per byte of file, plus the
/// allowance: VDB stores constant regions as tiles, so large ratios are real,
/// but a claim far beyond them is not data, it is a corrupt or hostile file.
inline constexpr uint64_t kMaxDenseExpansion = 4096;
inline constexpr uint64_t kDenseAllowanceBytes = uint64_t{64} << 20;

struct GridEntry {
    std::string name;       // without OpenVDB's unique-name suffix
    std::string tree_type;  // e.g. Tree_float_5_4_3 (a _HalfFloat suffix removed)
    uint64_t grid_pos = 0, block_pos = 0, end_pos = 0;
    /// Grid metadata values of at most 4 KiB: name -> (type name, raw bytes).
    std::map<std::string, std::pair<std::string, std::string>> meta;
};

struct VdbLayout {
    uint32_t version = 0;
    std::vector<GridEntry> grids;
};

/// Throws BadMagic / UnsupportedVersion / UnsupportedFeature / Truncated /
/// CorruptData naming `file`.
VdbLayout check_vdb_layout(const std::string& file, uint64_t file_size);

/// "float", "double", "int32", ... of a tree type name ("" if not of that form).
std::string value_type_of_tree(const std::string& tree_type);

/// Bytes per voxel of the dense volume tetlod builds for a grid value type (0: not scalar).
std::size_t dense_value_bytes(const std::string& value_type);

/// Dims from a dims_xyz metadata value: "vec3i" (three int32) or "string" with
/// exactly three positive integers. Anything else: CorruptData naming the value.
Dims parse_dims_xyz(const std::string& type_name, const std::string& raw_or_text, const std::string& what);

/// TooLarge unless dims x value_bytes <= file_size x kMaxDenseExpansion + allowance.
void check_dense_bound(const Dims& dims, std::size_t value_bytes, uint64_t file_size, const std::string& what,
                       const std::string& source);

/// Early refusal of the grid read_vdb would pick (by name, or the only scalar
/// grid): its dims_xyz metadata must parse and stay within the dense bound.
void check_selected_grid_claims(const VdbLayout& layout, const std::string& grid_name, uint64_t file_size,
                                const std::string& what);

}  // namespace tetlod::vdb_guard
