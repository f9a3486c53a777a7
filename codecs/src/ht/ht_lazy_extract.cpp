// Lazy extraction from a container: one refinement pass that decodes, through
// a bounded cache, exactly the chunks whose errors and values it examines.
#include "ht_chunk_cache.hpp"
#include "ht_chunk_decoder.hpp"

namespace tetlod {

using namespace ht_detail;

Expected<TetMesh> extract_ht_lazy(tlod::ContainerReader& r, const LodQuery& query, HtExtractStats* es,
                                  HtLazyStats* ls, const HtLazyOptions& options) {
    auto layout = read_ht_layout(r);
    if (!layout) return layout.failure();
    const HtLayout& L = *layout;
    HtChunkCache cache(r, L, options.cache_bytes);
    CachedSampleSource source(cache);
    auto mesh = capture([&] { return refine_ht(L.domain, source, query, es); }, "");
    if (!mesh) return mesh.failure();
    mesh->geometry.spacing = L.metadata.spacing;
    mesh->geometry.origin = L.metadata.origin;
    mesh->field_name = L.metadata.field_name();
    mesh->value_type = L.metadata.type;
    if (ls) {
        const ChunkCacheStats cs = cache.stats();
        ls->chunks_total = L.chunks.size();
        ls->chunks_decoded = cs.distinct;
        ls->chunk_decodes = cs.decodes;
        ls->cache_peak_bytes = cs.peak_bytes;
        ls->passes = 1;
        ls->bytes_read = r.bytes_read();
    }
    return mesh;
}

}  // namespace tetlod
