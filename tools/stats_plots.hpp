#pragma once
// The SVG plots and CSV tables of `tetlod stats --plot` and `tetlod compare`,
// drawn from the measurements of tetlod/analysis/model_stats.hpp.
#include <string>
#include <utility>
#include <vector>

#include "cli_common.hpp"

namespace tetlod::cli {

/// Writes the SVG plots and stats.csv into `dir` (created). Returns the file names
/// written (relative to dir), plots first, with a one-line caption each.
std::vector<std::pair<std::string, std::string>> write_stats_plots(
    const std::vector<ModelStats>& models, const std::string& dir, const std::string& dataset);

}  // namespace tetlod::cli
