// Making a LodModel: built from a volume or opened from a file (see model.hpp).
#include "tetlod/model.hpp"

#include <filesystem>
#include <new>

#include "tetlod/analysis/stopwatch.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/container.hpp"
#include "tetlod/converters/volume_formats.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

namespace {

LodModel open_container_model(const std::string& path, ModelKind kind) {
    Stopwatch clock;
    LodModel m;
    if (kind == ModelKind::Mt) {
        // load_mt_model throws (naming the file) when the container has no MT.
        m = make_lod_model(std::make_shared<const MtModel>(load_mt_model(path)));
        m.stored_what = ".tlod file (all models in it)";
    } else {
        m = make_lod_model(std::make_shared<const HtModel>(load_ht_model(path)));
        m.stored_what = ".tlod file";
    }
    m.build_seconds = clock.seconds();
    m.stored_bytes = std::filesystem::file_size(path);
    m.from_container = true;
    return m;
}

}  // namespace

ModelKind choose_model(const std::string& path, std::optional<ModelKind> requested) {
    if (!is_container_path(path)) return requested.value_or(ModelKind::Ht);
    const ContainerModels held = container_models(path);
    if (!held.ht && !held.mt) return requested.value_or(ModelKind::Ht);  // unreadable: the reader says why
    const ModelKind only = held.ht ? ModelKind::Ht : ModelKind::Mt;
    if (!requested) return held.ht && held.mt ? ModelKind::Ht : only;
    const bool has = *requested == ModelKind::Ht ? held.ht : held.mt;
    if (!has)
        throw Error(ErrorCode::InvalidArgument, "'" + path + "' holds no " + model_kind_name(*requested) +
                                                    " (it holds the " + model_kind_name(only) + ")");
    return *requested;
}

LodModel build_model(ModelKind kind, Volume volume, const ModelBuildOptions& options) {
    Stopwatch clock;
    if (kind == ModelKind::Ht) {
        // The metadata only when encoding: computing it scans the volume.
        const tlod::Metadata meta =
            options.measure_storage ? tlod::metadata_for_volume(volume) : tlod::Metadata{};
        HtBuildOptions o;
        o.pad = options.pad;
        auto ht = std::make_shared<const HtModel>(HtModel::build(std::move(volume), o));
        LodModel m = make_lod_model(ht);
        m.build_seconds = clock.seconds();
        if (options.measure_storage) {
            tlod::ContainerWriter w;
            encode_ht(*ht, meta, w);
            m.stored_bytes = w.finish().size();
            m.stored_what = ".tlod container (HT, zstd)";
        }
        return m;
    }
    MtBuildOptions mo;
    mo.max_shape_ratio = options.mt_max_shape_ratio;
    mo.progress = options.mt_progress;
    auto mt = std::make_shared<const MtModel>(MtModel::build(std::move(volume), mo));
    LodModel m = make_lod_model(mt);
    m.build_seconds = clock.seconds();
    if (options.measure_storage) {
        MtEncodeOptions eo;
        eo.include_field = true;
        m.stored_bytes = encode_mt(*mt, eo).size();
        m.stored_what = "encode_mt with field (zstd)";
    }
    if (options.measure_storage && !mt->updates().empty()) {
        LodQuery full;
        full.full = true;
        const double full_tets = double(mt->extract(full).tet_count());
        m.tets_per_split = (full_tets - double(mt->base_tets().size())) / double(mt->updates().size());
    }
    return m;
}

Expected<Volume> read_volume_file(const std::string& path, const VolumeReadOptions& read) {
    return capture([&] { return read_volume(path, read); });
}

Expected<LodModel> open_model(const std::string& path, ModelKind kind, const VolumeReadOptions& read,
                              const ModelBuildOptions& options) {
    if (is_container_path(path)) return capture([&] { return open_container_model(path, kind); });
    auto volume = read_volume_file(path, read);
    if (!volume) return volume.failure();
    return build_model(kind, std::move(*volume), options);
}

}  // namespace tetlod
