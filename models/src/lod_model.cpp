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

TetMesh LodModel::extract(const LodQuery& q, LodExtractStats* stats) const {
    if (kind == ModelKind::Ht) {
        HtExtractStats s;
        TetMesh mesh = ht->extract(q, &s);
        if (stats) *stats = {s.max_error, uint64_t(s.visited_tets), uint64_t(s.split_diamonds), 0};
        return mesh;
    }
    MtExtractStats s;
    TetMesh mesh = mt->extract(q, &s);
    if (stats)
        *stats = {s.max_error, uint64_t(s.visited_tets), uint64_t(s.splits), uint64_t(s.forced_splits)};
    return mesh;
}

void LodModel::extract_to(const LodQuery& q, TetMeshSink& sink, LodExtractStats* stats) const {
    if (kind == ModelKind::Ht) {
        HtExtractStats s;
        ht->extract_to(q, sink, &s);
        if (stats) *stats = {s.max_error, uint64_t(s.visited_tets), uint64_t(s.split_diamonds), 0};
        return;
    }
    send_mesh(extract(q, stats), sink);
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
    m.ht_k = ht->domain().k;
    m.ht_padded = ht->domain().padded;
    m.field_error = ht->field_error_bound();
    m.ht = std::move(ht);
    return m;
}

LodModel make_lod_model(std::shared_ptr<const MtModel> mt) {
    LodModel m;
    m.kind = ModelKind::Mt;
    m.dims = mt->dims();
    m.range = mt->value_range();
    m.memory_bytes = mt->field().bytes() + mt->base_tets().size() * 16 +
                     mt->updates().size() * sizeof(MtSplit) + mt->mask_bits().size() * 8;
    m.updates = mt->updates().size();
    m.mt_base_tets = mt->base_tets().size();
    m.field_error = mt->field_error_bound();
    m.mt = std::move(mt);
    return m;
}

}  // namespace tetlod
