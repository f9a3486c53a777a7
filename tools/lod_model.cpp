#include "lod_model.hpp"

#include <filesystem>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

namespace tetlod::cli {

const char* model_kind_name(ModelKind k) { return k == ModelKind::Ht ? "HT" : "MT"; }

ModelKind parse_model_kind(const std::string& text) {
    if (text == "ht" || text == "HT") return ModelKind::Ht;
    if (text == "mt" || text == "MT") return ModelKind::Mt;
    throw Error(ErrorCode::InvalidArgument, "--model '" + text + "': expected ht or mt");
}

ContainerModels container_models(const std::string& path) {
    ContainerModels m;
    auto r = tlod::ContainerReader::open(path);
    if (!r) return m;
    m.ht = (r->header().required_features & tlod::kFeatureHt) != 0;
    m.mt = container_has_mt(*r);
    return m;
}

std::string resolve_model(const std::string& given, const std::string& input) {
    if (!container_input(input)) return given.empty() ? "ht" : given;
    const ContainerModels m = container_models(input);
    if (!m.ht && !m.mt) return given.empty() ? "ht" : given;  // unreadable: the reader says why
    if (given.empty()) return m.mt && !m.ht ? "mt" : "ht";   // the only model present
    if ((given == "ht" && !m.ht) || (given == "mt" && !m.mt))
        throw Error(ErrorCode::InvalidArgument,
                    "--model " + given + ": '" + input + "' holds no " + (given == "ht" ? "HT" : "MT") +
                        " (it holds the " + (m.ht ? "HT" : "MT") + "; drop --model or use --model " +
                        (m.ht ? "ht" : "mt") + ")");
    return given;
}

Volume mt_container_volume(const std::string& path, const MtModel& mt) {
    Volume v = mt.field();
    auto r = tlod::ContainerReader::open(path);
    if (!r) throw Error(r.failure().code, r.failure().message);
    auto layout = read_mt_layout(*r);
    if (!layout) throw Error(layout.failure().code, layout.failure().message);
    const tlod::Metadata& meta = layout->metadata;
    v.spacing = meta.spacing;
    v.origin = meta.origin;
    v.field_name = meta.field_name();
    v.units = meta.units();
    for (const auto& [k, val] : meta.user_keys) v.metadata[k] = val;
    return v;
}

TetMesh LodModel::extract(const LodQuery& q) const {
    return kind == ModelKind::Ht ? ht->extract(q) : mt->extract(q);
}

LodModel build_model(ModelKind kind, Volume volume, bool pad, bool measure_storage) {
    LodModel m;
    m.kind = kind;
    Stopwatch clock;
    if (kind == ModelKind::Ht) {
        const tlod::Metadata meta = tlod::metadata_for_volume(volume);
        HtBuildOptions o;
        o.pad = pad;
        auto ht = std::make_shared<HtModel>(HtModel::build(std::move(volume), o));
        m.build_seconds = clock.seconds();
        m.dims = ht->field().dims;
        m.range = ht->value_range();
        m.memory_bytes = ht->field().bytes() + ht->diamond_errors().size() * sizeof(float);
        m.updates = uint64_t(m.dims.count()) - 8;
        if (measure_storage) {
            tlod::ContainerWriter w;
            encode_ht(*ht, meta, w);
            m.stored_bytes = w.finish().size();
            m.stored_what = ".tlod container (HT, zstd)";
        }
        m.ht = std::move(ht);
    } else {
        auto mt = std::make_shared<MtModel>(MtModel::build(std::move(volume)));
        m.build_seconds = clock.seconds();
        m.dims = mt->dims();
        m.range = mt->value_range();
        m.memory_bytes = mt->field().bytes() + mt->base_tets().size() * 16 +
                         mt->updates().size() * sizeof(MtUpdate) + mt->mask_bits().size() * 8;
        m.updates = mt->updates().size();
        if (measure_storage) {
            MtEncodeOptions eo;
            eo.include_field = true;
            m.stored_bytes = encode_mt(*mt, eo).size();
            m.stored_what = "encode_mt with field (zstd)";
        }
        if (!mt->updates().empty()) {
            LodQuery full;
            full.full = true;
            const double full_tets = double(mt->extract(full).tet_count());
            m.tets_per_split = (full_tets - double(mt->base_tets().size())) / double(mt->updates().size());
        }
        m.mt = std::move(mt);
    }
    return m;
}

LodModel load_model(const std::string& path, ModelKind kind, const VolumeFlags& flags, bool pad,
                    bool measure_storage) {
    if (container_input(path)) {
        if (kind == ModelKind::Mt) {
            // load_mt_model throws (naming the file) when the container has no MT.
            LodModel m;
            m.kind = ModelKind::Mt;
            Stopwatch clock;
            auto mt = std::make_shared<MtModel>(load_mt_model(path));
            m.build_seconds = clock.seconds();
            m.dims = mt->dims();
            m.range = mt->value_range();
            m.memory_bytes = mt->field().bytes() + mt->base_tets().size() * 16 +
                             mt->updates().size() * sizeof(MtUpdate) + mt->mask_bits().size() * 8;
            m.updates = mt->updates().size();
            m.stored_bytes = std::filesystem::file_size(path);
            m.stored_what = ".tlod file (all models in it)";
            m.from_container = true;
            m.mt = std::move(mt);
            return m;
        }
        LodModel m;
        Stopwatch clock;
        auto ht = std::make_shared<HtModel>(load_ht_model(path));
        m.build_seconds = clock.seconds();
        m.dims = ht->field().dims;
        m.range = ht->value_range();
        m.memory_bytes = ht->field().bytes() + ht->diamond_errors().size() * sizeof(float);
        m.updates = uint64_t(m.dims.count()) - 8;
        m.stored_bytes = std::filesystem::file_size(path);
        m.stored_what = ".tlod file";
        m.from_container = true;
        m.ht = std::move(ht);
        return m;
    }
    return build_model(kind, load_volume(path, flags.options()), pad, measure_storage);
}

}  // namespace tetlod::cli
