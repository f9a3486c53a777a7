#pragma once
// One handle for either multiresolution model (HT or MT) with what every
// consumer asks of it: its kind, grid, value range, sizes, and the LOD query.
// Holds the model by shared pointer, so copies are cheap and share it; the
// model itself is immutable, so concurrent extract() calls are safe.
// Trust: a LodModel holds a model that was built in memory or came through a
// decoder's validation, so its queries need no further checks on the input.
//
// How a LodModel is made (built from a volume, or read from a file) lives in
// the public API (tetlod/model.hpp); this type sits here so that analysis/ can
// measure a model without depending on the API layer.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"
#include "tetlod/core/triangle_mesh.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/models/lod_query.hpp"

namespace tetlod {

class HtModel;
class MtModel;

enum class ModelKind { Ht, Mt };
/// "HT" or "MT".
const char* model_kind_name(ModelKind kind);
/// "ht"/"HT" or "mt"/"MT"; anything else: nullopt.
std::optional<ModelKind> parse_model_kind(const std::string& text);

/// What an extraction did (for reports).
struct LodExtractStats {
    double max_error = 0;         // largest error bound of the mesh's tets
    uint64_t visited_tets = 0;    // tets the refinement examined
    uint64_t splits = 0;          // HT: diamonds split; MT: vertex splits applied
    uint64_t forced_splits = 0;   // MT: splits forced by dependencies (HT: 0)
};

struct LodModel {
    ModelKind kind = ModelKind::Ht;
    /// Exactly one is set, matching `kind`.
    std::shared_ptr<const HtModel> ht;
    std::shared_ptr<const MtModel> mt;
    Dims dims;                          // grid of the data (HT: of the padded cube when padded)
    std::array<double, 2> range{0, 0};  // smallest and largest field value
    double build_seconds = 0;           // build or load time
    /// Bytes of the model as stored (from a container: the file's size; built
    /// with measure_storage: the encoded model), 0 when not measured; and the
    /// model's in-memory arrays.
    uint64_t stored_bytes = 0, memory_bytes = 0;
    std::string stored_what;            // what stored_bytes measured
    /// MT only: net tets added per vertex split, (full mesh - base mesh) / updates.
    std::optional<double> tets_per_split;
    uint64_t updates = 0;               // MT: vertex splits; HT: diamonds (grid points - 8)
    bool from_container = false;        // read from a .tlod (build_seconds = load time)
    int ht_k = 0;                       // HT: the cube's side is 2^k
    bool ht_padded = false;             // HT: built on the padded cube
    uint64_t mt_base_tets = 0;          // MT: tets of the base mesh
    /// A lossy container's field (format 3.1, 3.5 with the MT): every stored
    /// sample is within this of the original, and the finest tets state it as
    /// their error, so a threshold below it gives the finest mesh. 0: lossless.
    double field_error = 0;

    uint64_t grid_points() const { return uint64_t(dims.count()); }
    /// The mesh of a selective-refinement query (any thresholds, box, isovalues).
    /// Throws tetlod::Error(CorruptData) only if the model is inconsistent, which
    /// a model that passed its decoder's validation never is.
    TetMesh extract(const LodQuery& query, LodExtractStats* stats = nullptr) const;
    /// The same mesh handed to `sink` in parts: streamed by the HT (memory
    /// does not grow with the tets), extracted whole then handed over by the MT.
    void extract_to(const LodQuery& query, TetMeshSink& sink, LodExtractStats* stats = nullptr) const;
    /// Marching tetrahedra on the mesh of `query` for each of `isovalues` (see
    /// tetlod/models/isosurface.hpp; throws InvalidArgument on a NaN isovalue).
    TriangleMesh isosurface(const LodQuery& query, std::span<const double> isovalues) const;
};

/// The LodModel view of an already built model: fills dims, range, memory_bytes
/// and updates (timings, stored sizes and tets_per_split are the maker's).
LodModel make_lod_model(std::shared_ptr<const HtModel> ht);
LodModel make_lod_model(std::shared_ptr<const MtModel> mt);

}  // namespace tetlod
