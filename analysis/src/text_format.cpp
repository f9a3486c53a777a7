// Number formatting shared by every report (see text_format.hpp).
#include "tetlod/analysis/text_format.hpp"

#include <cmath>
#include <cstdio>

namespace tetlod {

std::string format_bytes(uint64_t bytes) {
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    double v = static_cast<double>(bytes);
    int u = 0;
    while (v >= 1024.0 && u < 4) {
        v /= 1024.0;
        ++u;
    }
    char buf[32];
    if (u == 0)
        std::snprintf(buf, sizeof buf, "%llu B", static_cast<unsigned long long>(bytes));
    else
        std::snprintf(buf, sizeof buf, "%.1f %s", v, units[u]);
    return buf;
}

std::string format_seconds(double s) {
    char buf[32];
    if (s < 1.0)
        std::snprintf(buf, sizeof buf, "%.0f ms", s * 1000.0);
    else
        std::snprintf(buf, sizeof buf, "%.2f s", s);
    return buf;
}

std::string format_dims(const Dims& d, char sep) {
    return std::to_string(d.x) + sep + std::to_string(d.y) + sep + std::to_string(d.z);
}

std::string format_number(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

std::string format_error(double error, const std::array<double, 2>& range) {
    if (error < 0) return "full resolution";
    const double width = range[1] - range[0];
    if (std::isinf(error) || !(width > 0)) return format_number(error);
    char pct[32];
    std::snprintf(pct, sizeof pct, "%.3g", error * 100.0 / width);  // 3 digits: 0.98%, 10%
    return format_number(error) + " (" + pct + "% of range)";
}

}  // namespace tetlod
