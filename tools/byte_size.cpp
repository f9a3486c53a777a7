// The --memory size syntax. See byte_size.hpp.
#include "byte_size.hpp"

#include <cctype>
#include <charconv>
#include <cmath>

namespace tetlod::cli {

std::optional<std::size_t> byte_size_from(const std::string& text, std::string& why) {
    // A number, then optionally K, M, G or T (powers of 1024, as zstd's
    // --memory), optionally followed by "B" or "iB".
    std::size_t n = 0;
    while (n < text.size() && (std::isdigit(static_cast<unsigned char>(text[n])) || text[n] == '.')) ++n;
    double v = 0.0;
    auto [p, ec] = std::from_chars(text.data(), text.data() + n, v);
    if (n == 0 || ec != std::errc() || p != text.data() + n || !std::isfinite(v)) {
        why = "expected a size such as 512M, 2G or 1073741824";
        return std::nullopt;
    }
    std::string unit = text.substr(n);
    for (char& c : unit) c = char(std::toupper(static_cast<unsigned char>(c)));
    if (unit.size() >= 2 && unit.substr(unit.size() - 2) == "IB") unit.resize(unit.size() - 2);
    else if (unit.size() >= 2 && unit.back() == 'B') unit.pop_back();
    double scale = 1;
    if (unit == "K") scale = 1024.0;
    else if (unit == "M") scale = 1024.0 * 1024;
    else if (unit == "G") scale = 1024.0 * 1024 * 1024;
    else if (unit == "T") scale = 1024.0 * 1024 * 1024 * 1024;
    else if (!unit.empty() && unit != "B") {
        why = "unknown unit '" + text.substr(n) + "' (K, M, G or T)";
        return std::nullopt;
    }
    const double bytes = v * scale;
    if (bytes < 1 || bytes > 1e18) {
        why = "out of range";
        return std::nullopt;
    }
    return std::size_t(bytes);
}

}  // namespace tetlod::cli
