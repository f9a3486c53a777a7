#pragma once
// The METADATA section (spec/tlod-format.md §5): the volume's geometry and value
// type, its value range, and two key/value lists: format keys (field name, units,
// provenance; names fixed by the spec) and user keys (carried through verbatim).
#include <array>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::tlod {

// Format key names (spec §5.3).
inline constexpr const char* kKeyFieldName = "field.name";
inline constexpr const char* kKeyFieldUnits = "field.units";
inline constexpr const char* kKeySourceName = "source.name";
inline constexpr const char* kKeySourceXxh64 = "source.xxh64";
inline constexpr const char* kKeySourceSize = "source.size";
inline constexpr const char* kKeyConverter = "converter";
inline constexpr const char* kKeyToolVersion = "tool.version";
inline constexpr const char* kKeyCreated = "created";
inline constexpr const char* kKeyHtErrorMax = "ht.error.max";
inline constexpr const char* kKeyHtAlwaysSplit = "ht.error.always_split";
/// 3.1, with the LOSSY feature only: E, every stored sample within E of the
/// original (decimal, shortest text that reads back as the same double).
inline constexpr const char* kKeyFieldMaxError = "field.max_error";

struct Metadata {
    Dims dims;                  // of the original volume
    ValueType type = ValueType::U8;
    Vec3 spacing{1, 1, 1};
    Vec3 origin{0, 0, 0};
    std::array<double, 2> value_range{0, 0};
    std::map<std::string, std::string> format_keys;
    std::map<std::string, std::string> user_keys;

    std::string field_name() const;
    std::string units() const;
};

/// Limits a reader enforces on a METADATA section (and a writer refuses to exceed).
inline constexpr std::size_t kMaxMetadataEntries = 65536;
inline constexpr std::size_t kMaxKeyBytes = 65535;

/// Throws tetlod::Error when the result would not parse back (the writer never
/// produces a METADATA section parse_metadata refuses: dims, type, non-finite or
/// non-positive spacing, non-finite origin, min > max, key rules).
std::vector<std::byte> serialize_metadata(const Metadata& m);
/// Parses and validates a decompressed METADATA section: dims within the core
/// limits (before anything is allocated from them), a known value type, reserved
/// bytes zero, no duplicate keys, no trailing bytes. Safe on untrusted input.
Expected<Metadata> parse_metadata(std::span<const std::byte> raw);

/// Metadata describing a volume (keys from volume.metadata become user keys).
Metadata metadata_for_volume(const Volume& v);
/// The same for a volume known by its header and value range only (one read
/// plane by plane; `header.data` is not looked at).
Metadata metadata_for_volume(const Volume& header, std::array<double, 2> range);

}  // namespace tetlod::tlod
