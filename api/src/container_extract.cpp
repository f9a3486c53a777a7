// A LOD mesh out of a container: the HT lazily, the MT decoded whole (see
// container.hpp).
#include <filesystem>

#include "tetlod/analysis/stopwatch.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/container.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

namespace {

// What both models report before extracting: the data's description, and the
// query with its thresholds resolved against the stored value range.
ContainerExtract described(ModelKind model, const tlod::Metadata& meta, LodQuery& query,
                           const ThresholdResolver& resolve) {
    ContainerExtract x;
    x.model = model;
    x.dims = meta.dims;
    x.type = meta.type;
    x.range = meta.value_range;
    if (resolve) resolve(query, x.range);
    x.query = query;
    return x;
}

/// A lossy file's E (0: lossless): the HT layout's, which checked it (spec §5.1).
double field_max_error(tlod::ContainerReader& r) {
    auto ht = read_ht_layout(r);
    return ht ? ht->max_error : 0.0;
}

Expected<ContainerExtract> extract_mt(const std::string& path, tlod::ContainerReader& r, LodQuery query,
                                      const ThresholdResolver& resolve, const Stopwatch& clock, TetMeshSink* sink) {
    if (!container_has_mt(r))
        return fail(ErrorCode::NotFound, "'" + path + "': --model mt: the container holds no MT "
                                         "(write one with `tetlod convert IN OUT.tlod --model ht,mt`)");
    auto layout = read_mt_layout(r);
    if (!layout) return layout.failure();
    auto model = decode_mt_container(r);
    if (!model) return model.failure();
    ContainerExtract x = described(ModelKind::Mt, layout->metadata, query, resolve);
    MtExtractStats stats;
    auto mesh = capture([&] { return model->extract(query, &stats); });  // CorruptData on an inconsistent MT
    if (!mesh) return mesh.failure();
    x.tet_count = mesh->tets.size();
    x.vertex_count = mesh->points.size();
    if (sink) {
        auto sent = capture([&] { send_mesh(*mesh, *sink); });
        if (!sent) return sent.failure();
    } else {
        x.mesh = std::move(*mesh);
    }
    x.seconds = clock.seconds();
    x.mt_updates = model->updates().size();
    x.mt_field_from_ht = layout->with_ht;
    x.max_error = stats.max_error;
    x.field_max_error = layout->with_ht ? field_max_error(r) : 0.0;
    return x;
}

Expected<ContainerExtract> extract(const std::string& path, ModelKind model, LodQuery query,
                                   const ThresholdResolver& resolve, const ContainerExtractOptions& options,
                                   TetMeshSink* sink) {
    Stopwatch clock;
    auto r = tlod::ContainerReader::open(path);
    if (!r) return r.failure();
    if (model == ModelKind::Mt) return extract_mt(path, *r, std::move(query), resolve, clock, sink);
    auto layout = read_ht_layout(*r);
    if (!layout) return layout.failure();
    ContainerExtract x = described(ModelKind::Ht, layout->metadata, query, resolve);
    HtExtractStats stats;
    HtLazyStats lazy;
    HtLazyOptions lo;
    lo.cache_bytes = options.cache_bytes;
    lo.progress = options.progress;
    if (sink) {
        TetMeshCounter counted(*sink);
        auto done = extract_ht_lazy_to(*r, query, counted, &stats, &lazy, lo);
        if (!done) return done.failure();
        x.tet_count = counted.tets;
        x.vertex_count = counted.vertices;
    } else {
        auto mesh = extract_ht_lazy(*r, query, &stats, &lazy, lo);
        if (!mesh) return mesh.failure();
        x.mesh = std::move(*mesh);
        x.tet_count = x.mesh.tets.size();
        x.vertex_count = x.mesh.points.size();
    }
    x.seconds = clock.seconds();
    x.max_error = stats.max_error;
    x.field_max_error = layout->max_error;
    x.refine_seconds = stats.refine_seconds;
    x.emit_seconds = stats.emit_seconds;
    x.bytes_read = lazy.bytes_read;
    x.distinct_bytes_read = lazy.distinct_bytes_read;
    x.chunks_decoded = lazy.chunks_decoded;
    x.chunks_total = lazy.chunks_total;
    x.passes = lazy.passes;
    x.chunk_decodes = lazy.chunk_decodes;
    x.cache_peak_bytes = lazy.cache_peak_bytes;
    std::error_code ec;
    x.file_size = std::filesystem::file_size(path, ec);
    return x;
}

}  // namespace

Expected<ContainerExtract> extract_from_container(const std::string& path, ModelKind model, LodQuery query,
                                                  const ThresholdResolver& resolve,
                                                  const ContainerExtractOptions& options) {
    return extract(path, model, std::move(query), resolve, options, nullptr);
}

Expected<ContainerExtract> extract_from_container_to(const std::string& path, ModelKind model, LodQuery query,
                                                     TetMeshSink& sink, const ThresholdResolver& resolve,
                                                     const ContainerExtractOptions& options) {
    return extract(path, model, std::move(query), resolve, options, &sink);
}

}  // namespace tetlod
