#pragma once
// Making a model: build an HT or MT from a volume in memory, or open the model
// behind a file (a .tlod container's stored model, or any volume file read and
// built). The model type itself, LodModel, is in tetlod/models/lod_model.hpp.
//
// Trust: open_model reads untrusted files safely: a malformed, truncated or
// hostile file gives an Error naming the file, never a crash or unbounded
// allocation. build_model works on trusted in-memory data (a Volume whose
// data size matches dims x type).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/models/lod_model.hpp"
#include "tetlod/models/mt/mt_shape_cap.hpp"

namespace tetlod {

struct ModelBuildOptions {
    /// HT only: embed the data in the enclosing (2^k+1)^3 cube (coarser meshes
    /// that cover the padded cube).
    bool pad = false;
    /// Also measure what the comparison reports: encode the model to count
    /// stored_bytes and, for the MT, extract its full mesh for tets_per_split.
    bool measure_storage = false;
    /// MT only: the largest circumradius / shortest edge ratio a collapse may
    /// create (MtBuildOptions::max_shape_ratio; mt_shape_cap.hpp); 0: no cap.
    double mt_max_shape_ratio = kDefaultMtMaxShapeRatio;
    /// MT only: progress of the build (MtBuildOptions::progress: (done, total)
    /// from TBB worker threads, one call at a time). The HT build does not report.
    std::function<void(uint64_t done, uint64_t total)> mt_progress = {};
};

/// Builds `kind` from `volume` (moved in). Throws tetlod::Error(InvalidArgument)
/// for a volume the model cannot represent (e.g. a dimension below 2).
LodModel build_model(ModelKind kind, Volume volume, const ModelBuildOptions& options = {});

/// Which model of `path` to use. Given `requested`: that model, unless `path` is
/// a container that lacks it (InvalidArgument naming the file and the model it
/// holds). Not given: a container's only model when it holds just one, else the
/// HT (a volume file builds either; the HT is the default). Reads only the
/// container's header and section table; an unreadable container is left to the
/// reader that opens it next, which says why.
ModelKind choose_model(const std::string& path, std::optional<ModelKind> requested = std::nullopt);

/// The model of `path`: from a .tlod container (recognised by its first bytes or
/// the .tlod extension) the stored HT or MT; an MT request on a container without
/// one is a NotFound error naming the file. Any other path is read as a volume
/// (raw, NRRD, MetaImage, OpenVDB, FILE.h5:/dataset, with `read`) and `kind` built.
/// Every failure is returned, never thrown; messages name the file.
Expected<LodModel> open_model(const std::string& path, ModelKind kind,
                              const VolumeReadOptions& read = {},
                              const ModelBuildOptions& options = {});

/// Reads a volume file of any supported format (see tetlod/converters/volume_formats.hpp).
/// Safe on untrusted files; failures are returned naming the file.
Expected<Volume> read_volume_file(const std::string& path, const VolumeReadOptions& read = {});

}  // namespace tetlod
