#pragma once
// The measurements behind `tetlod stats` and `tetlod compare`, after the
// experimental section of Danovaro, De Floriani, Lee, Samet ("Multiresolution
// tetrahedral meshes: an analysis and a comparison"): tets against the error
// threshold for uniform, box and isovalue queries, isosurface sizes, shape
// quality, storage and extraction times; and their JSON and text forms.
// Works on a model already in memory (trusted); never reads files.
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tetlod/analysis/shape_quality.hpp"
#include "tetlod/models/lod_model.hpp"

namespace tetlod {

struct StatsOptions {
    /// Error thresholds as fractions of the value range.
    std::vector<double> error_fractions{0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5};
    /// Isovalues for the isovalue queries; empty: 25%, 50%, 75% of the range.
    std::vector<double> isovalues;
    /// Threshold (fraction of range) of the uniform mesh whose quality is reported.
    double quality_fraction = 0.01;
};

/// One threshold of one query type, averaged over its queries.
struct QueryRow {
    double error = 0, fraction = 0;
    double tets = 0, vertices = 0, faces = 0;  // faces: isovalue queries only
    double seconds = 0;                        // mean extraction time per query
    int queries = 0;
};

struct ModelStats {
    std::string name;  // "HT", "MT"
    Dims dims;
    std::array<double, 2> range{0, 0};
    uint64_t grid_points = 0, stored_bytes = 0, memory_bytes = 0, updates = 0;
    std::string stored_what;
    double build_seconds = 0;
    bool from_container = false;
    double field_error = 0;  // LodModel::field_error (lossy container), 0: lossless
    uint64_t full_tets = 0, full_vertices = 0;
    double full_seconds = 0;
    std::optional<double> tets_per_split;
    std::vector<QueryRow> uniform, box, iso;
    std::vector<double> isovalues;
    int boxes = 0;  // boxes per threshold
    ShapeQualityStats quality_full, quality_lod;
    double quality_lod_error = 0;
};

/// Runs every query on `model`. Deterministic apart from the times.
ModelStats measure_model(const LodModel& model, const std::string& name, const StatsOptions& options = {});

/// One JSON object per model (the `stats --json` document).
nlohmann::json stats_json(const std::vector<ModelStats>& models);
/// Plain-text summary for a terminal.
std::string stats_text(const std::vector<ModelStats>& models);

}  // namespace tetlod
