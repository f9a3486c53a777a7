#pragma once
// The multiresolution model behind a tool's input, whichever kind it is: the HT
// of a .tlod file, or an HT or MT built from a volume. Lets isosurface, stats and
// compare run the same queries on every model without knowing which it is.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "tetlod/models/lod_query.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {
class HtModel;
class MtModel;
}

namespace tetlod::cli {

struct VolumeFlags;

enum class ModelKind { Ht, Mt };
const char* model_kind_name(ModelKind k);  // "HT", "MT"

struct LodModel {
    ModelKind kind = ModelKind::Ht;
    std::shared_ptr<const HtModel> ht;
    std::shared_ptr<const MtModel> mt;
    Dims dims;                         // grid of the data (HT: of the padded cube when padded)
    std::array<double, 2> range{0, 0};
    double build_seconds = 0;          // build or load time
    /// Bytes of the model as stored (HT: .tlod container; MT: encode_mt with the
    /// field), and the model's in-memory arrays.
    uint64_t stored_bytes = 0, memory_bytes = 0;
    std::string stored_what;           // what stored_bytes measured
    /// MT only: net tets added per vertex split, (full mesh - base mesh) / updates.
    std::optional<double> tets_per_split;
    uint64_t updates = 0;              // MT: vertex splits; HT: diamonds (grid points - 8)
    bool from_container = false;       // loaded from a .tlod (build_seconds = load time)

    uint64_t grid_points() const { return uint64_t(dims.count()); }
    TetMesh extract(const LodQuery& q) const;
};

/// Builds `kind` from a volume (moved in). `pad` applies to the HT only.
/// `measure_storage` also encodes the model to count its stored bytes.
LodModel build_model(ModelKind kind, Volume volume, bool pad, bool measure_storage);

/// Loads the model of `path`: from a .tlod file the stored HT or MT (an MT request
/// on a file without one throws, naming the file); any volume file is read with
/// `flags` and the model built.
LodModel load_model(const std::string& path, ModelKind kind, const VolumeFlags& flags, bool pad,
                    bool measure_storage);

ModelKind parse_model_kind(const std::string& text);

/// The models a .tlod holds (both false when it cannot be opened: the reader
/// used next reports why).
struct ContainerModels {
    bool ht = false, mt = false;
};
ContainerModels container_models(const std::string& path);

/// --model as given; when not given (empty), the only model of a container that
/// holds just an MT is "mt", everything else "ht".
std::string resolve_model(const std::string& given, const std::string& input);

/// The volume an MT-only container stores (its MT's field), described by the
/// container's metadata (spacing, origin, field name, units, user keys).
Volume mt_container_volume(const std::string& path, const MtModel& mt);

}  // namespace tetlod::cli
