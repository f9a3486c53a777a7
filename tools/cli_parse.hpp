#pragma once
// Text -> value parsers of the flags both command lines read (numbers, --box,
// --error, --error-out): `tetlod` (cli_common, which turns a refusal into a
// tetlod::Error naming the flag) and `tetlod-mpi` must accept and refuse the
// same texts. Standard library only, as byte_size.hpp: tetlod-mpi cannot
// include "tetlod/tetlod.hpp".
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace tetlod::cli {

/// The comma-separated fields of `text`, empty ones kept ("1,,2" has three),
/// so a missing field is reported rather than silently merged.
std::vector<std::string> comma_fields(const std::string& text);

/// A decimal integer that fits int64; nothing else in the text.
std::optional<int64_t> integer_from(const std::string& text);

/// A finite decimal number ("0.5", "-1", "1e3"); no spaces, nothing after it.
std::optional<double> finite_number_from(const std::string& text, std::string& why);

/// An inclusive index box "x0,y0,z0,x1,y1,z1" of integers with x0 <= x1,
/// y0 <= y1, z0 <= z1 ("8.0" is not an integer).
std::optional<std::array<int64_t, 6>> index_box_from(const std::string& text, std::string& why);

/// An error bound as typed: absolute ("0.5"), percent of the value range
/// ("0.1%"), unbounded ("inf", "unbounded", "infinity"), or negative for full
/// resolution.
struct ErrorThreshold {
    double value = 0.0;
    bool percent = false;
    /// Field units for a volume with value range [lo, hi]: percent * (hi - lo) / 100
    /// (multiplied first so 1% of 255 is exactly 2.55). Negative stays negative.
    double resolve(const std::array<double, 2>& range) const;
};
std::optional<ErrorThreshold> error_threshold_from(const std::string& text, std::string& why);

}  // namespace tetlod::cli
