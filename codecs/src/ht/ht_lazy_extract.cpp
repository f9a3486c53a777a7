// Lazy extraction from a container: one refinement pass that decodes, through
// a bounded cache, exactly the chunks whose errors and values it examines.
#include "ht_chunk_cache.hpp"
#include "ht_chunk_decoder.hpp"

namespace tetlod {

using namespace ht_detail;

namespace {

TetMesh labels_of(const tlod::Metadata& md) {
    TetMesh m;
    m.geometry.spacing = md.spacing;
    m.geometry.origin = md.origin;
    m.field_name = md.field_name();
    m.value_type = md.type;
    return m;
}

void report(const HtLayout& L, const HtChunkCache& cache, const tlod::ContainerReader& r, HtLazyStats* ls) {
    if (!ls) return;
    const ChunkCacheStats cs = cache.stats();
    ls->chunks_total = L.chunks.size();
    ls->chunks_decoded = cs.distinct;
    ls->chunk_decodes = cs.decodes;
    ls->cache_peak_bytes = cs.peak_bytes;
    ls->passes = 1;
    ls->bytes_read = r.bytes_read();
    ls->distinct_bytes_read = r.distinct_bytes_read();
}

void watch(HtChunkCache& cache, const HtLayout& L, const HtLazyOptions& o) {
    if (!o.progress) return;
    const uint64_t total = L.chunks.size();
    cache.on_decode([&o, total](const ChunkCacheStats& s) { o.progress(s.distinct, total); });
}

}  // namespace

Expected<TetMesh> extract_ht_lazy(tlod::ContainerReader& r, const LodQuery& query, HtExtractStats* es,
                                  HtLazyStats* ls, const HtLazyOptions& options) {
    auto layout = read_ht_layout(r);
    if (!layout) return layout.failure();
    const HtLayout& L = *layout;
    HtChunkCache cache(r, L, options.cache_bytes);
    watch(cache, L, options);
    CachedSampleSource source(cache);
    auto mesh = capture([&] { return refine_ht(L.domain, source, query, es); });
    if (!mesh) return mesh.failure();
    const TetMesh labels = labels_of(L.metadata);
    mesh->geometry = labels.geometry;
    mesh->field_name = labels.field_name;
    mesh->value_type = labels.value_type;
    report(L, cache, r, ls);
    return mesh;
}

Expected<Done> extract_ht_lazy_to(tlod::ContainerReader& r, const LodQuery& query, TetMeshSink& sink,
                                  HtExtractStats* es, HtLazyStats* ls, const HtLazyOptions& options,
                                  const HtEmitShare& share) {
    auto layout = read_ht_layout(r);
    if (!layout) return layout.failure();
    const HtLayout& L = *layout;
    HtChunkCache cache(r, L, options.cache_bytes);
    watch(cache, L, options);
    CachedSampleSource source(cache);
    auto done = capture([&] { refine_ht_to(L.domain, source, query, labels_of(L.metadata), sink, es, share); });
    if (!done) return done.failure();
    report(L, cache, r, ls);
    return done;
}

}  // namespace tetlod
