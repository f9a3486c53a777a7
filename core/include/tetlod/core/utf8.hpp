#pragma once
// UTF-8 validation for text that leaves tetlod as text (metadata keys, JSON,
// HDF5 UTF-8 attributes): well-formed sequences only (no overlongs, no UTF-16
// surrogates, nothing above U+10FFFF).
#include <cstddef>
#include <string_view>

namespace tetlod {

/// True when `s` is well-formed UTF-8.
bool is_valid_utf8(std::string_view s);

/// Offset of the first byte that breaks UTF-8, or s.size() when valid.
std::size_t first_invalid_utf8(std::string_view s);

}  // namespace tetlod
