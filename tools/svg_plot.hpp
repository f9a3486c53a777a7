#pragma once
// A small self-contained SVG chart writer for `tetlod stats --plot` and
// `tetlod compare`: line charts (linear or log axes) and histograms, with
// labelled axes, tick labels and a legend outside the plot area so it never
// covers data. No dependencies; output is plain SVG 1.1 any browser renders.
#include <string>
#include <vector>

namespace tetlod::cli {

struct PlotSeries {
    std::string label;
    std::vector<double> x, y;  // lines: points; histogram: x = bin edges (y.size() + 1)
    bool dashed = false;
    /// Palette index; -1: the series' position. Series of one model share a colour.
    int color = -1;
};

struct Plot {
    enum class Kind { Lines, Histogram };
    Kind kind = Kind::Lines;
    std::string title, subtitle, x_label, y_label;
    bool log_x = false, log_y = false;
    /// Optional vertical reference lines (e.g. published values), with labels.
    std::vector<std::pair<double, std::string>> x_marks;
    std::vector<PlotSeries> series;
};

/// Renders the plot as an SVG document. Points that cannot be shown (non-finite,
/// or <= 0 on a log axis) are left out; an empty plot says "no data".
std::string render_svg(const Plot& plot);

}  // namespace tetlod::cli
