// The LodModel view of either model (see lod_model.hpp).
#include "tetlod/models/lod_model.hpp"

#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/isosurface.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

const char* model_kind_name(ModelKind k) { return k == ModelKind::Ht ? "HT" : "MT"; }

std::optional<ModelKind> parse_model_kind(const std::string& text) {
    if (text == "ht" || text == "HT") return ModelKind::Ht;
    if (text == "mt" || text == "MT") return ModelKind::Mt;
    return std::nullopt;
}

TetMesh LodModel::extract(const LodQuery& q) const {
    return kind == ModelKind::Ht ? ht->extract(q) : mt->extract(q);
}

TriangleMesh LodModel::isosurface(const LodQuery& query, std::span<const double> isovalues) const {
    return marching_tetrahedra(extract(query), isovalues);
}

LodModel make_lod_model(std::shared_ptr<const HtModel> ht) {
    LodModel m;
    m.kind = ModelKind::Ht;
    m.dims = ht->field().dims;
    m.range = ht->value_range();
    m.memory_bytes = ht->field().bytes() + ht->diamond_errors().size() * sizeof(float);
    m.updates = uint64_t(m.dims.count()) - 8;
    m.ht = std::move(ht);
    return m;
}

LodModel make_lod_model(std::shared_ptr<const MtModel> mt) {
    LodModel m;
    m.kind = ModelKind::Mt;
    m.dims = mt->dims();
    m.range = mt->value_range();
    m.memory_bytes = mt->field().bytes() + mt->base_tets().size() * 16 +
                     mt->updates().size() * sizeof(MtUpdate) + mt->mask_bits().size() * 8;
    m.updates = mt->updates().size();
    m.mt = std::move(mt);
    return m;
}

}  // namespace tetlod
