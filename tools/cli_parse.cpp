#include "cli_parse.hpp"

#include <charconv>
#include <cmath>
#include <limits>

namespace tetlod::cli {

std::vector<std::string> comma_fields(const std::string& text) {
    std::vector<std::string> parts;
    std::size_t start = 0;
    while (true) {
        const auto comma = text.find(',', start);
        parts.push_back(text.substr(start, comma - start));
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return parts;
}

std::optional<int64_t> integer_from(const std::string& text) {
    int64_t v = 0;
    const char* end = text.data() + text.size();
    auto [p, ec] = std::from_chars(text.data(), end, v);
    if (ec != std::errc() || p != end) return std::nullopt;
    return v;
}

std::optional<double> finite_number_from(const std::string& text, std::string& why) {
    // from_chars, not stod: no locale, no leading spaces, no partial parse.
    double v = 0.0;
    const char* end = text.data() + text.size();
    auto [p, ec] = std::from_chars(text.data(), end, v);
    if (ec != std::errc() || p != end || text.empty() || !std::isfinite(v)) {
        why = "not a finite number";
        return std::nullopt;
    }
    return v;
}

std::optional<std::array<int64_t, 6>> index_box_from(const std::string& text, std::string& why) {
    const auto parts = comma_fields(text);
    if (parts.size() != 6) {
        why = "expected x0,y0,z0,x1,y1,z1";
        return std::nullopt;
    }
    std::array<int64_t, 6> b{};
    for (std::size_t i = 0; i < 6; ++i) {
        const auto v = integer_from(parts[i]);
        if (!v) {
            why = "'" + parts[i] + "' is not an integer";
            return std::nullopt;
        }
        b[i] = *v;
    }
    for (std::size_t a = 0; a < 3; ++a)
        if (b[a] > b[a + 3]) {
            why = "each lower corner must not exceed the upper one";
            return std::nullopt;
        }
    return b;
}

std::optional<ErrorThreshold> error_threshold_from(const std::string& text, std::string& why) {
    if (text == "inf" || text == "unbounded" || text == "infinity")
        return ErrorThreshold{std::numeric_limits<double>::infinity(), false};
    ErrorThreshold t;
    std::string number = text;
    if (!number.empty() && number.back() == '%') {
        t.percent = true;
        number.pop_back();
    }
    const auto v = finite_number_from(number, why);
    if (!v) return std::nullopt;
    t.value = *v;
    return t;
}

double ErrorThreshold::resolve(const std::array<double, 2>& range) const {
    // Negative means "full resolution" whatever the range; keep it clearly negative
    // (a negative percent of a zero range would otherwise become -0).
    if (value < 0) return -1.0;
    if (!percent) return value;
    return value * (range[1] - range[0]) / 100.0;
}

}  // namespace tetlod::cli
