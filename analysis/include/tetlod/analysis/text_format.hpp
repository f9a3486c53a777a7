#pragma once
// Numbers as the reports print them (stats text, the command line's summaries),
// so every tool formats sizes, times and errors the same way.
#include <array>
#include <cstdint>
#include <string>

#include "tetlod/core/volume.hpp"

namespace tetlod {

std::string format_bytes(uint64_t bytes);                // "1.5 MiB"
std::string format_seconds(double seconds);              // "12 ms", "3.40 s"
std::string format_dims(const Dims& d, char sep = 'x');  // "65x65x65"
std::string format_number(double v);                     // 6 significant digits: "2.55", "inf"
/// An error bound with its share of the value range: "2.55 (1% of range)".
std::string format_error(double error, const std::array<double, 2>& range);

}  // namespace tetlod
