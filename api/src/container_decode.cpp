// The volume a container stores, bit-exact (see container.hpp).
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/container.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

namespace {

// An MT-only container's volume: its MT's field, described by the metadata
// (spacing, origin, field name, units, user keys).
Expected<Volume> decode_mt_volume(tlod::ContainerReader& r) {
    auto layout = read_mt_layout(r);
    if (!layout) return layout.failure();
    auto mt = decode_mt_container(r);
    if (!mt) return mt.failure();
    Volume v = mt->field();
    const tlod::Metadata& meta = layout->metadata;
    v.spacing = meta.spacing;
    v.origin = meta.origin;
    v.field_name = meta.field_name();
    v.units = meta.units();
    for (const auto& [k, val] : meta.user_keys) v.metadata[k] = val;
    return v;
}

}  // namespace

Expected<Volume> decode_container(const std::string& path) {
    auto r = tlod::ContainerReader::open(path);
    if (!r) return r.failure();
    const bool has_ht = (r->header().required_features & tlod::kFeatureHt) != 0;
    if (!has_ht && container_has_mt(*r)) return decode_mt_volume(*r);
    return decode_volume(*r);
}

}  // namespace tetlod
