// HT -> container sections: METADATA, HT_HEADER, then per chunk its field and
// error sections (spec §6-§8).
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "ht_chunk_geometry.hpp"
#include "ht_container_parts.hpp"
#include "ht_chunk_modes.hpp"

namespace tetlod {

using namespace ht_detail;

bool encode_ht(const HtModel& model, const tlod::Metadata& meta, tlod::ContainerWriter& writer,
               const HtEncodeOptions& o) {
    if (o.brick_log2 < 1 || o.brick_log2 > 16)
        throw Error(ErrorCode::InvalidArgument, "brick_log2 must be in 1..16");
    if (o.error_mantissa_bits < 0 || o.error_mantissa_bits > 7)
        throw Error(ErrorCode::InvalidArgument, "error mantissa bits must be in 0..7");
    const HtDomain& d = model.domain();
    const Volume& f = model.field();
    if (f.type != meta.type || !(d.source_dims == meta.dims))
        throw Error(ErrorCode::InvalidArgument, "metadata does not describe the model's volume");
    const Geometry G = geometry_of(d, o.brick_log2);
    const std::vector<HtChunk> chunks = chunk_list(G);
    const int m = o.error_mantissa_bits;

    tlod::Metadata md = meta;
    {
        // In parallel (a maximum and a count: the same in any order): one pass
        // over every grid point's error, which ran alone before the chunks.
        const std::span<const float> errors(model.diamond_errors());
        const ErrorSummary summary = tbb::parallel_reduce(
            tbb::blocked_range<std::size_t>(0, errors.size(), std::size_t{1} << 16), ErrorSummary(m),
            [&](const tbb::blocked_range<std::size_t>& r, ErrorSummary sum) {
                for (std::size_t i = r.begin(); i < r.end(); ++i) sum.add(errors[i]);
                return sum;
            },
            [](ErrorSummary a, const ErrorSummary& b) {
                a.merge(b);
                return a;
            });
        summary.write_to(md);
    }
    writer.set_features(ht_features(md, o));
    writer.set_table(o.table);
    writer.add(tlod::kSectionMetadata, tlod::kSectionCritical, 0, 0, tlod::serialize_metadata(md),
               o.zstd_level);
    const auto hh = ht_header_bytes(d, o.brick_log2, m);
    writer.add_stored(tlod::kSectionHtHeader, tlod::kSectionCritical, 0, 0, hh, hh.size());

    std::vector<CodedSection> fs(chunks.size()), es(chunks.size());
    const ChunkModeChoice choice = chunk_mode_choice(o);
    // Parallel over chunks in batches so progress is reported from this thread.
    // Each chunk's mode depends on that chunk alone: same bytes for any thread count.
    const std::size_t batch = 64;
    uint64_t coded_bytes = 0;  // of the chunk sections so far: the file will hold at least these
    for (std::size_t s = 0; s < chunks.size(); s += batch) {
        const std::size_t e = std::min(chunks.size(), s + batch);
        // A chunk's field and errors are two tasks: with one chunk per cycle
        // (small volumes) a chunk a task left a core idle.
        tbb::parallel_for(
            2 * s, 2 * e,
            [&](std::size_t k) {
                const std::size_t i = k / 2;
                dispatch_value_type(f.type, [&](auto tv) {
                    using T = decltype(tv);
                    if (k % 2 == 0) fs[i] = encode_field_chunk_v3<T>(G, f.as<T>(), chunks[i], choice);
                    else es[i] = encode_error_chunk_v3<T>(G, f.as<T>(), model.diamond_errors(), chunks[i], m, choice);
                });
            },
            tbb::simple_partitioner());
        if (o.progress) o.progress(e, chunks.size());
        for (std::size_t i = s; i < e; ++i) coded_bytes += fs[i].bytes.size() + es[i].bytes.size();
        // Chunk sections alone (the table is compressed: not counted, its size
        // need not grow with every entry), so a lower bound of the file.
        if (o.give_up_at > 0 && coded_bytes >= o.give_up_at) return false;
    }
    for (std::size_t i = 0; i < chunks.size(); ++i) {
        writer.add_stored(tlod::kSectionHtField, fs[i].flags, uint32_t(chunks[i].cycle), chunks[i].brick,
                          std::move(fs[i].bytes), fs[i].raw_size);
        writer.add_stored(tlod::kSectionHtErrors, es[i].flags, uint32_t(chunks[i].cycle), chunks[i].brick,
                          std::move(es[i].bytes), es[i].raw_size);
    }
    return true;
}

void write_ht_container(const std::string& path, const HtModel& model, const tlod::Metadata& meta,
                        const HtEncodeOptions& options) {
    tlod::ContainerWriter w;
    // A writer it gave up on is incomplete: never a file.
    if (!encode_ht(model, meta, w, options))
        throw Error(ErrorCode::InvalidArgument, "'" + path + "': the encoding reached give_up_at (" +
                                                    std::to_string(options.give_up_at) + " bytes); nothing written");
    w.write(path);
}

}  // namespace tetlod
