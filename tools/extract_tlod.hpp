#pragma once
// `tetlod extract` on a .tlod container: lazy HT extraction (only the chunks
// the query examines are read and decoded) or extraction from the container's
// MT, shared by the extract subcommand.
#include <array>
#include <functional>
#include <string>

#include "tetlod/models/lod_query.hpp"

namespace tetlod::cli {

/// Query thresholds still to be resolved against the container's value range.
struct TlodExtractRequest {
    std::string input, output, format;
    LodQuery query;  // box, isovalues, full; error_in/error_out set by `resolve`
    std::function<double(const std::array<double, 2>&)> error_in, error_out;
    bool compress = true;
    /// "ht" (lazy, only the chunks the query examines) or "mt" (the MT is decoded whole).
    std::string model = "ht";
};

/// Extracts from a container and writes the mesh; prints a summary. Throws tetlod::Error.
int run_extract_tlod(TlodExtractRequest request);

}  // namespace tetlod::cli
