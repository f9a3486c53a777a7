#pragma once
// Decoded HT chunks on demand, in a bounded cache (the lazy extraction's data).
//
// A chunk is decoded on its own, in its window (window_for): the lattice of its
// cycle over its box grown by the predictor reach. Its coarser points are
// copied from the chunks holding them, fetched (and, when absent, decoded) the
// same way, so a chunk costs its own sections plus whatever coarser chunks are
// not cached already. Nothing is allocated per grid point of the volume.
//
// The cache keeps the most recently used chunks within a byte budget. Chunks
// in use (held by a reader, or fetched by the decoding in progress: at most a
// few per cycle) are never evicted, so the budget may be exceeded by what is
// in use; below the working set of a query, chunks are decoded again (same
// results, more time).
#include <tbb/task_group.h>

#include <cstddef>
#include <cstdint>
#include <condition_variable>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <vector>

#include "ht_chunk_geometry.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/models/ht/ht_sample_source.hpp"

namespace tetlod::ht_detail {

/// One chunk decoded in its window.
struct DecodedChunk {
    Geometry window;
    ValueType type = ValueType::U8;
    std::vector<std::byte> field;  // window points x value size
    std::vector<float> errors;     // per window point (valid at the chunk's own diamonds)
    std::size_t bytes() const { return field.capacity() + errors.capacity() * sizeof(float) + sizeof(*this); }
};

struct ChunkCacheStats {
    uint64_t decodes = 0;       // chunk decodings (a chunk evicted and needed again counts again)
    uint64_t distinct = 0;      // chunks decoded at least once
    std::size_t peak_bytes = 0; // largest cache content
};

class HtChunkCache {
public:
    /// `reader` and `layout` must outlive the cache. `errors`: decode the
    /// error sections too (false: the field only, for reading the volume).
    HtChunkCache(tlod::ContainerReader& reader, const HtLayout& layout, std::size_t budget_bytes,
                 bool errors = true);
    /// Waits for the background decodings (those not started are cancelled).
    ~HtChunkCache() noexcept;
    HtChunkCache(const HtChunkCache&) = delete;
    HtChunkCache& operator=(const HtChunkCache&) = delete;

    /// Index (file order) of the chunk holding grid point p of B, and its cycle.
    std::size_t chunk_of(const ht::Pt& p, int* cycle = nullptr) const;
    /// The decoded chunk `id`, decoding it when absent. Throws tetlod::Error
    /// (CorruptData, naming the container and section) on a bad chunk.
    std::shared_ptr<const DecodedChunk> get(std::size_t id);

    /// Decodes chunk `id` for a caller that uses it once (the finest rows of
    /// a volume read plane by plane): its coarser chunks come through the
    /// cache, its own decoding runs outside the lock, so callers decode in
    /// parallel, and is not kept. `errors`: decode its error section too.
    std::shared_ptr<const DecodedChunk> decode_uncached(std::size_t id, bool errors);

    /// Starts decoding chunk `id` in the background (a TBB task) unless it is
    /// cached, being decoded or queued, or the cache is over half its budget
    /// (what is prefetched should not evict what is in use). A failure there
    /// is dropped: the reader meets it again when it asks for the chunk.
    void prefetch(std::size_t id);

    ChunkCacheStats stats() const;
    /// Called after each decoding (under the cache's lock: one call at a time).
    void on_decode(std::function<void(const ChunkCacheStats&)> f) { on_decode_ = std::move(f); }
    const HtLayout& layout() const { return L_; }

private:
    /// The chunks one fetch has copied from, held until it is done: with a
    /// tiny budget, re-fetching coarser chunks for every dependency would cost
    /// exponentially in the cycles.
    using Pins = std::vector<std::shared_ptr<const DecodedChunk>>;
    /// A coarser chunk for a fetch in progress (under `lock`, which a wait for
    /// a chunk another thread is decoding releases).
    std::shared_ptr<const DecodedChunk> get_locked(std::size_t id, std::unique_lock<std::mutex>& lock, Pins& pins);
    /// A chunk's window with its coarser points filled, and its sections.
    struct Prepared {
        std::shared_ptr<DecodedChunk> chunk;
        std::vector<std::byte> field_stored, error_stored;
    };
    Prepared prepare(std::size_t id, bool errors, std::unique_lock<std::mutex>& lock, Pins& pins);  // under the lock
    void finish(std::size_t id, Prepared& p);      // the decoding proper, lock-free
    /// Puts a decoded chunk in the cache and wakes the threads waiting for it (under the lock).
    void store(std::size_t id, const std::shared_ptr<const DecodedChunk>& c);
    void evict_over_budget(std::size_t keep);

    tlod::ContainerReader& r_;
    const HtLayout& L_;
    const Geometry G_;
    const std::size_t budget_;
    const bool errors_;
    std::vector<std::size_t> first_of_cycle_;
    struct CycleBricks {
        int shift = 0;          // log2 of the brick side
        int64_t n[3] = {1, 1, 1};  // bricks per axis
        std::size_t first = 0;  // index of the cycle's first chunk
    };
    std::vector<CycleBricks> cycle_bricks_;  // per cycle, for chunk_of
    mutable std::mutex mu_;
    struct Slot {
        std::shared_ptr<const DecodedChunk> chunk;
        std::list<std::size_t>::iterator lru;
        bool seen = false;
        bool pending = false;  // being decoded by a thread outside the lock
        bool queued = false;   // a background decoding is queued (prefetch)
    };
    std::condition_variable decoded_;  // a pending chunk is done
    std::vector<Slot> slots_;
    std::list<std::size_t> lru_;  // most recent first
    std::size_t bytes_ = 0;
    ChunkCacheStats stats_;
    std::function<void(const ChunkCacheStats&)> on_decode_;
    tbb::task_group background_;  // prefetches; waited for by the destructor
};

/// HtSampleSource over a chunk cache: remembers the last chunk per cycle, so
/// the refinement's neighbouring reads rarely take the cache's lock.
class CachedSampleSource final : public HtSampleSource {
public:
    explicit CachedSampleSource(HtChunkCache& cache);
    float error(const Point& p) override;
    double value(const Point& p) override;
    /// The layout's E (spec §5.1) rounded up to float: what a lossy reader adds to every stored bound.
    float field_error_bound() override;
    std::unique_ptr<HtSampleSource> fork() override;
    /// Queues the chunks holding `points` for background decoding.
    void prefetch(const Point* points, int count) override;

private:
    const DecodedChunk& at(const Point& p);
    HtChunkCache& cache_;
    std::size_t last_prefetch_ = SIZE_MAX;  // consecutive hints mostly name one chunk
    struct Memo {
        std::size_t id = SIZE_MAX;
        std::shared_ptr<const DecodedChunk> chunk;
    };
    std::vector<Memo> memo_;  // per cycle
};

}  // namespace tetlod::ht_detail
