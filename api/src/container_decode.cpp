// The volume a container stores, bit-exact, alone or with the stored model
// (see container.hpp).
#include <algorithm>
#include <filesystem>

#include "tetlod/analysis/stopwatch.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/container.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

namespace {

// An MT-only container's volume: its MT's field, described by the metadata
// (spacing, origin, field name, units, user keys).
Volume described_mt_field(const MtModel& mt, const tlod::Metadata& meta) {
    Volume v = mt.field();
    v.spacing = meta.spacing;
    v.origin = meta.origin;
    v.field_name = meta.field_name();
    v.units = meta.units();
    for (const auto& [k, val] : meta.user_keys) v.metadata[k] = val;
    return v;
}

Expected<StoredModel> stored_mt(tlod::ContainerReader& r) {
    auto layout = read_mt_layout(r);
    if (!layout) return layout.failure();
    auto mt = decode_mt_container(r);
    if (!mt) return mt.failure();
    auto shared = std::make_shared<const MtModel>(std::move(*mt));
    StoredModel s{make_lod_model(shared), described_mt_field(*shared, layout->metadata)};
    s.model.stored_what = ".tlod file (all models in it)";
    return s;
}

Expected<StoredModel> stored_ht(tlod::ContainerReader& r) {
    auto d = decode_ht(r);
    if (!d) return d.failure();
    // The original (unpadded) volume: the data's corner of the decoded field.
    auto original = capture([&] { return crop_volume(d->field, d->layout.metadata.dims); });
    if (!original) return original.failure();
    auto ht = std::make_shared<const HtModel>(
        HtModel::from_parts(std::move(d->field), d->layout.domain, std::move(d->errors), d->layout.max_error));
    StoredModel s{make_lod_model(ht), std::move(*original)};
    s.model.stored_what = ".tlod file";
    return s;
}

}  // namespace

Expected<Volume> decode_container(const std::string& path, const std::function<void(uint64_t, uint64_t)>& progress) {
    auto r = tlod::ContainerReader::open(path);
    if (!r) return r.failure();
    const bool has_ht = (r->header().required_features & tlod::kFeatureHt) != 0;
    if (!has_ht && container_has_mt(*r)) {
        auto layout = read_mt_layout(*r);
        if (!layout) return layout.failure();
        auto mt = decode_mt_container(*r);
        if (!mt) return mt.failure();
        return described_mt_field(*mt, layout->metadata);
    }
    return decode_volume(*r, progress);
}

Expected<std::unique_ptr<VolumePlanes>> open_container_planes(const std::string& path, std::size_t cache_bytes) {
    const ContainerModels m = container_models(path);
    if (!m.ht && m.mt) {
        auto v = decode_container(path);
        if (!v) return v.failure();
        return planes_owning(std::move(*v));
    }
    return open_ht_planes(path, cache_bytes);
}

Expected<StoredModel> open_stored_model(const std::string& path, ModelKind model) {
    Stopwatch clock;
    auto r = tlod::ContainerReader::open(path);
    if (!r) return r.failure();
    auto s = model == ModelKind::Mt ? stored_mt(*r) : stored_ht(*r);
    if (!s) return s;
    s->model.build_seconds = clock.seconds();
    std::error_code ec;
    s->model.stored_bytes = std::filesystem::file_size(path, ec);
    s->model.from_container = true;
    return s;
}

}  // namespace tetlod
