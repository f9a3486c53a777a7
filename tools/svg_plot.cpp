// SVG charts. Layout: title and subtitle on top, plot area on the left, legend
// in a column to its right, axis labels outside the ticks. Log axes get ticks at
// 1-2-5 steps per decade when they span few decades, powers of ten otherwise.
#include "svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace tetlod::cli {

namespace {

constexpr double kWidth = 820, kHeight = 480;
constexpr double kLeft = 86, kRight = 620, kTop = 64, kBottom = 410;  // plot area
const char* const kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                               "#9467bd", "#8c564b", "#17becf", "#7f7f7f"};

std::string esc(const std::string& s) {
    std::string r;
    for (char c : s) {
        if (c == '&') r += "&amp;";
        else if (c == '<') r += "&lt;";
        else if (c == '>') r += "&gt;";
        else if (c == '"') r += "&quot;";
        else r += c;
    }
    return r;
}

std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.2f", v);
    return b;
}

// Tick label: compact, no trailing zeros, SI-ish suffixes for large values.
std::string tick_label(double v) {
    char b[32];
    const double a = std::abs(v);
    if (a == 0) return "0";
    if (a >= 1e6 && std::fmod(a, 1e5) == 0) std::snprintf(b, sizeof b, "%gM", v / 1e6);
    else if (a >= 1e4 && std::fmod(a, 100) == 0) std::snprintf(b, sizeof b, "%gk", v / 1e3);
    else if (a < 1e-3 || a >= 1e7) std::snprintf(b, sizeof b, "%.0e", v);
    else std::snprintf(b, sizeof b, "%g", v);
    return b;
}

struct Axis {
    bool log = false;
    double lo = 0, hi = 1;  // data range after padding (log: of values, not exponents)
    double p0 = 0, p1 = 1;  // pixel range

    double t(double v) const { return log ? std::log10(v) : v; }
    double px(double v) const {
        const double a = t(lo), b = t(hi);
        return p0 + (t(v) - a) / (b - a) * (p1 - p0);
    }
    bool shows(double v) const { return std::isfinite(v) && (!log || v > 0); }

    void fit(double mn, double mx, bool zero_based, bool margin) {
        if (!(mn <= mx)) mn = log ? 1 : 0, mx = log ? 10 : 1;
        if (log) {
            // A little headroom so no marker sits on the frame.
            if (margin) mn /= 1.06, mx *= 1.06;
            lo = std::pow(10, std::floor(std::log10(mn)));
            hi = std::pow(10, std::ceil(std::log10(mx)));
            if (hi <= lo) hi = lo * 10;
            // Whole decades leave much empty space: tighten to 1-2-5 bounds.
            for (double m : {5.0, 2.0}) {
                const double l2 = lo * m;
                if (l2 <= mn) { lo = l2; break; }
            }
            for (double m : {0.2, 0.5}) {
                const double h2 = hi * m;
                if (h2 >= mx) { hi = h2; break; }
            }
            return;
        }
        if (zero_based && mn > 0) mn = 0;
        if (mx == mn) mx = mn + 1;
        if (margin) mx += 0.03 * (mx - mn);
        const double step = nice_step((mx - mn) / 6);
        lo = std::floor(mn / step) * step;
        hi = std::ceil(mx / step) * step;
    }
    static double nice_step(double raw) {
        const double p = std::pow(10, std::floor(std::log10(raw)));
        for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
            if (m * p >= raw) return m * p;
        return 10 * p;
    }
    std::vector<double> ticks() const {
        std::vector<double> r;
        if (log) {
            const int d0 = int(std::floor(std::log10(lo) + 1e-9)), d1 = int(std::ceil(std::log10(hi) - 1e-9));
            auto collect = [&](std::vector<double> mantissas) {
                r.clear();
                for (int d = d0; d <= d1; ++d)
                    for (double m : mantissas) {
                        const double v = m * std::pow(10, d);
                        if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) r.push_back(v);
                    }
            };
            // Fewer than four powers of ten in view: label 2 and 5 as well.
            collect({1});
            if (r.size() < 4) collect({1, 2, 5});
            // Many decades: label every other one.
            if (r.size() > 12) {
                std::vector<double> k;
                for (std::size_t i = 0; i < r.size(); i += 2) k.push_back(r[i]);
                r = k;
            }
            return r;
        }
        const double step = nice_step((hi - lo) / 6);
        for (double v = lo; v <= hi + step * 1e-9; v += step) r.push_back(std::abs(v) < step * 1e-9 ? 0 : v);
        return r;
    }
};

}  // namespace

std::string render_svg(const Plot& plot) {
    double xmn = std::numeric_limits<double>::infinity(), xmx = -xmn, ymn = xmn, ymx = -xmn;
    bool any = false;
    for (const auto& s : plot.series) {
        for (std::size_t i = 0; i < s.x.size(); ++i) {
            const bool ok_x = std::isfinite(s.x[i]) && (!plot.log_x || s.x[i] > 0);
            if (ok_x) xmn = std::min(xmn, s.x[i]), xmx = std::max(xmx, s.x[i]);
        }
        for (std::size_t i = 0; i < s.y.size(); ++i) {
            const bool ok_y = std::isfinite(s.y[i]) && (!plot.log_y || s.y[i] > 0);
            if (ok_y) ymn = std::min(ymn, s.y[i]), ymx = std::max(ymx, s.y[i]), any = true;
        }
    }
    for (const auto& [x, label] : plot.x_marks)
        if (std::isfinite(x)) xmn = std::min(xmn, x), xmx = std::max(xmx, x);
    Axis ax, ay;
    ax.log = plot.log_x, ay.log = plot.log_y;
    ax.p0 = kLeft, ax.p1 = kRight, ay.p0 = kBottom, ay.p1 = kTop;
    // Headroom keeps markers off the frame; bars may touch it, and bin edges
    // are the x range of a histogram.
    const bool lines = plot.kind == Plot::Kind::Lines;
    ax.fit(xmn, xmx, false, lines);
    ay.fit(ymn, ymx, !lines || !plot.log_y, lines);

    std::string o;
    o += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + num(kWidth) + "\" height=\"" +
         num(kHeight) + "\" viewBox=\"0 0 " + num(kWidth) + " " + num(kHeight) +
         "\" font-family=\"Helvetica, Arial, sans-serif\">\n";
    o += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    o += "<text x=\"" + num(kLeft) + "\" y=\"26\" font-size=\"17\" font-weight=\"bold\">" +
         esc(plot.title) + "</text>\n";
    if (!plot.subtitle.empty())
        o += "<text x=\"" + num(kLeft) + "\" y=\"46\" font-size=\"12\" fill=\"#555\">" +
             esc(plot.subtitle) + "</text>\n";
    // Grid and ticks.
    for (double v : ax.ticks()) {
        const double x = ax.px(v);
        o += "<line x1=\"" + num(x) + "\" y1=\"" + num(kTop) + "\" x2=\"" + num(x) + "\" y2=\"" +
             num(kBottom) + "\" stroke=\"#e4e4e4\"/>\n";
        o += "<text x=\"" + num(x) + "\" y=\"" + num(kBottom + 17) +
             "\" font-size=\"11\" text-anchor=\"middle\">" + esc(tick_label(v)) + "</text>\n";
    }
    for (double v : ay.ticks()) {
        const double y = ay.px(v);
        o += "<line x1=\"" + num(kLeft) + "\" y1=\"" + num(y) + "\" x2=\"" + num(kRight) +
             "\" y2=\"" + num(y) + "\" stroke=\"#e4e4e4\"/>\n";
        o += "<text x=\"" + num(kLeft - 6) + "\" y=\"" + num(y + 4) +
             "\" font-size=\"11\" text-anchor=\"end\">" + esc(tick_label(v)) + "</text>\n";
    }
    o += "<rect x=\"" + num(kLeft) + "\" y=\"" + num(kTop) + "\" width=\"" + num(kRight - kLeft) +
         "\" height=\"" + num(kBottom - kTop) + "\" fill=\"none\" stroke=\"#333\"/>\n";
    o += "<text x=\"" + num((kLeft + kRight) / 2) + "\" y=\"" + num(kBottom + 42) +
         "\" font-size=\"13\" text-anchor=\"middle\">" + esc(plot.x_label) +
         (plot.log_x ? " (log scale)" : "") + "</text>\n";
    o += "<text transform=\"translate(22," + num((kTop + kBottom) / 2) +
         ") rotate(-90)\" font-size=\"13\" text-anchor=\"middle\">" + esc(plot.y_label) +
         (plot.log_y ? " (log scale)" : "") + "</text>\n";
    if (!any)
        o += "<text x=\"" + num((kLeft + kRight) / 2) + "\" y=\"" + num((kTop + kBottom) / 2) +
             "\" font-size=\"16\" fill=\"#999\" text-anchor=\"middle\">no data</text>\n";

    // Reference marks.
    for (const auto& [x, label] : plot.x_marks) {
        if (!ax.shows(x)) continue;
        const double px = ax.px(x);
        o += "<line x1=\"" + num(px) + "\" y1=\"" + num(kTop) + "\" x2=\"" + num(px) + "\" y2=\"" +
             num(kBottom) + "\" stroke=\"#444\" stroke-dasharray=\"2,3\"/>\n";
        // Vertical, along the line's right side from the top: never runs into bars
        // or other marks to its right.
        o += "<text transform=\"translate(" + num(px + 11) + "," + num(kTop + 6) +
             ") rotate(90)\" font-size=\"10\" fill=\"#444\">" + esc(label) + "</text>\n";
    }

    // Data, clipped to the plot area.
    o += "<clipPath id=\"area\"><rect x=\"" + num(kLeft) + "\" y=\"" + num(kTop) + "\" width=\"" +
         num(kRight - kLeft) + "\" height=\"" + num(kBottom - kTop) + "\"/></clipPath>\n";
    o += "<g clip-path=\"url(#area)\">\n";
    for (std::size_t si = 0; si < plot.series.size(); ++si) {
        const auto& s = plot.series[si];
        const std::string color = kColors[(s.color >= 0 ? std::size_t(s.color) : si) % 8];
        const std::string dash = s.dashed ? " stroke-dasharray=\"6,4\"" : "";
        if (plot.kind == Plot::Kind::Histogram) {
            if (s.x.size() != s.y.size() + 1) continue;
            std::string path;
            const double base = ay.px(ay.log ? ay.lo : std::max(ay.lo, 0.0));
            for (std::size_t i = 0; i < s.y.size(); ++i) {
                const double x0 = ax.px(s.x[i]), x1 = ax.px(s.x[i + 1]);
                const double y = ay.shows(s.y[i]) ? ay.px(s.y[i]) : base;
                path += (i == 0 ? "M" + num(x0) + "," + num(base) + " L" : " L") + num(x0) + "," +
                        num(y) + " L" + num(x1) + "," + num(y);
            }
            if (!s.y.empty()) path += " L" + num(ax.px(s.x.back())) + "," + num(base) + " Z";
            o += "<path d=\"" + path + "\" fill=\"" + color + "\" fill-opacity=\"0.18\" stroke=\"" +
                 color + "\" stroke-width=\"1.8\"" + dash + "/>\n";
            continue;
        }
        std::string pts;
        std::vector<std::pair<double, double>> marks;
        for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
            if (!ax.shows(s.x[i]) || !ay.shows(s.y[i])) continue;
            const double x = ax.px(s.x[i]), y = ay.px(s.y[i]);
            pts += (pts.empty() ? "" : " ") + num(x) + "," + num(y);
            marks.emplace_back(x, y);
        }
        if (marks.size() > 1)
            o += "<polyline points=\"" + pts + "\" fill=\"none\" stroke=\"" + color +
                 "\" stroke-width=\"2\"" + dash + "/>\n";
        for (const auto& [x, y] : marks)
            o += "<circle cx=\"" + num(x) + "\" cy=\"" + num(y) + "\" r=\"3.2\" fill=\"" + color +
                 "\"/>\n";
    }
    o += "</g>\n";

    // Legend column right of the plot.
    double ly = kTop + 8;
    for (std::size_t si = 0; si < plot.series.size(); ++si) {
        const auto& s = plot.series[si];
        const std::string color = kColors[(s.color >= 0 ? std::size_t(s.color) : si) % 8];
        const std::string dash = s.dashed ? " stroke-dasharray=\"6,4\"" : "";
        o += "<line x1=\"" + num(kRight + 16) + "\" y1=\"" + num(ly) + "\" x2=\"" + num(kRight + 42) +
             "\" y2=\"" + num(ly) + "\" stroke=\"" + color + "\" stroke-width=\"" +
             (plot.kind == Plot::Kind::Histogram ? "6" : "2.5") + "\"" + dash + "/>\n";
        // Long labels wrap onto a second line at a space.
        std::string a = s.label, b;
        if (a.size() > 22) {
            const auto cut = a.rfind(' ', 22);
            if (cut != std::string::npos) b = a.substr(cut + 1), a = a.substr(0, cut);
        }
        o += "<text x=\"" + num(kRight + 48) + "\" y=\"" + num(ly + 4) + "\" font-size=\"12\">" +
             esc(a) + "</text>\n";
        if (!b.empty()) {
            ly += 15;
            o += "<text x=\"" + num(kRight + 48) + "\" y=\"" + num(ly + 4) + "\" font-size=\"12\">" +
                 esc(b) + "</text>\n";
        }
        ly += 22;
    }
    o += "</svg>\n";
    return o;
}

}  // namespace tetlod::cli
