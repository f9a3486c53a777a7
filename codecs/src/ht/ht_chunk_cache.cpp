// Decoded HT chunks on demand, in a bounded cache.
#include "ht_chunk_cache.hpp"

#include <bit>
#include <cstring>

#include "ht_chunk_decoder.hpp"
#include "tetlod/core/float_bound.hpp"

namespace tetlod::ht_detail {

namespace {

/// Copies n values of vs bytes from src to dst, the i-th at i·ds / i·dd values
/// along each.
template <std::size_t Vs>
void copy_row_of(std::byte* dst, int64_t dd, const std::byte* src, int64_t ds, int64_t n) {
    for (int64_t i = 0; i < n; ++i, dst += dd * int64_t(Vs), src += ds * int64_t(Vs)) std::memcpy(dst, src, Vs);
}
void copy_row(std::byte* dst, int64_t dd, const std::byte* src, int64_t ds, int64_t n, std::size_t vs) {
    switch (vs) {
        case 1: return copy_row_of<1>(dst, dd, src, ds, n);
        case 2: return copy_row_of<2>(dst, dd, src, ds, n);
        case 4: return copy_row_of<4>(dst, dd, src, ds, n);
        case 8: return copy_row_of<8>(dst, dd, src, ds, n);
        default:
            for (int64_t i = 0; i < n; ++i) std::memcpy(dst + i * dd * int64_t(vs), src + i * ds * int64_t(vs), vs);
    }
}

}  // namespace

HtChunkCache::HtChunkCache(tlod::ContainerReader& reader, const HtLayout& layout, std::size_t budget_bytes,
                           bool errors)
    : r_(reader),
      L_(layout),
      G_(geometry_of(layout.domain, layout.brick_log2)),
      budget_(budget_bytes),
      errors_(errors),
      first_of_cycle_(std::size_t(G_.k + 1), 0),
      slots_(layout.chunks.size()) {
    for (std::size_t i = L_.chunks.size(); i-- > 0;) first_of_cycle_[std::size_t(L_.chunks[i].cycle)] = i;
    cycle_bricks_.resize(std::size_t(G_.k + 1));
    for (int t = 0; t <= G_.k; ++t) {
        CycleBricks& c = cycle_bricks_[std::size_t(t)];
        c.shift = t + 1 + G_.g;  // side(t) = 2^shift
        const auto n = G_.bricks(t);
        for (int a = 0; a < 3; ++a) c.n[a] = n[a];
        c.first = first_of_cycle_[std::size_t(t)];
    }
}

std::size_t HtChunkCache::chunk_of(const ht::Pt& p, int* cycle) const {
    // Every sample the refinement reads comes through here: shifts and a
    // table, no divisions.
    const uint32_t any = uint32_t(p[0]) | uint32_t(p[1]) | uint32_t(p[2]);
    const int t = any == 0 ? G_.k : std::min(G_.k, std::countr_zero(any));
    const CycleBricks& c = cycle_bricks_[std::size_t(t)];
    int64_t bi[3];
    for (int a = 0; a < 3; ++a) bi[a] = std::min<int64_t>(int64_t(p[a]) >> c.shift, c.n[a] - 1);
    if (cycle) *cycle = t;
    return c.first + std::size_t((bi[2] * c.n[1] + bi[1]) * c.n[0] + bi[0]);
}

std::shared_ptr<const DecodedChunk> HtChunkCache::get(std::size_t id) {
    Prepared p;
    {
        std::unique_lock<std::mutex> lock(mu_);
        for (;;) {
            Slot& s = slots_[id];
            if (s.chunk) {
                lru_.splice(lru_.begin(), lru_, s.lru);
                return s.chunk;
            }
            if (!s.pending) break;
            decoded_.wait(lock);  // another thread is decoding it
        }
        // Its coarser points are gathered under the lock (decoding missing
        // coarser chunks there); the chunk's own decoding, the bulk of the
        // work, runs outside, so threads asking for different chunks decode
        // in parallel.
        slots_[id].pending = true;
        try {
            Pins pins;
            p = prepare(id, errors_, lock, pins);
        } catch (...) {
            slots_[id].pending = false;
            decoded_.notify_all();
            throw;
        }
    }
    try {
        finish(id, p);
    } catch (...) {
        std::lock_guard<std::mutex> lock(mu_);
        slots_[id].pending = false;
        decoded_.notify_all();
        throw;
    }
    std::lock_guard<std::mutex> lock(mu_);
    std::shared_ptr<const DecodedChunk> c = p.chunk;
    store(id, c);
    evict_over_budget(id);
    return c;
}

HtChunkCache::~HtChunkCache() noexcept {
    background_.cancel();
    background_.wait();
}

void HtChunkCache::prefetch(std::size_t id) {
    {
        std::lock_guard<std::mutex> lock(mu_);
        Slot& s = slots_[id];
        if (s.chunk || s.pending || s.queued || bytes_ > budget_ / 2) return;
        s.queued = true;
    }
    background_.run([this, id] {
        try {
            get(id);
        } catch (...) {
            // Dropped: the reader decodes the chunk itself when it needs it, and
            // gets the error there, with its context.
        }
        std::lock_guard<std::mutex> lock(mu_);
        slots_[id].queued = false;
    });
}

ChunkCacheStats HtChunkCache::stats() const {
    std::lock_guard<std::mutex> lock(mu_);
    return stats_;
}

std::shared_ptr<const DecodedChunk> HtChunkCache::get_locked(std::size_t id, std::unique_lock<std::mutex>& lock,
                                                             Pins& pins) {
    for (;;) {
        Slot& s = slots_[id];
        if (s.chunk) {
            lru_.splice(lru_.begin(), lru_, s.lru);
            pins.push_back(s.chunk);
            return s.chunk;
        }
        if (!s.pending) break;
        // Another thread decodes it (outside the lock): wait rather than decode
        // it twice. What this fetch holds is pinned in `pins`, so the wait
        // cannot lose it; waits only go to coarser chunks, so they cannot cycle.
        decoded_.wait(lock);
    }
    slots_[id].pending = true;
    Prepared p;
    try {
        p = prepare(id, errors_, lock, pins);
        finish(id, p);  // under the lock: the caller needs it now
    } catch (...) {
        slots_[id].pending = false;
        decoded_.notify_all();
        throw;
    }
    std::shared_ptr<const DecodedChunk> c = p.chunk;
    store(id, c);
    pins.push_back(c);
    return c;
}

void HtChunkCache::store(std::size_t id, const std::shared_ptr<const DecodedChunk>& c) {
    Slot& slot = slots_[id];
    slot.pending = false;
    slot.chunk = c;
    lru_.push_front(id);
    slot.lru = lru_.begin();
    bytes_ += c->bytes();
    stats_.decodes += 1;
    stats_.distinct += slot.seen ? 0 : 1;
    slot.seen = true;
    stats_.peak_bytes = std::max(stats_.peak_bytes, bytes_);
    if (on_decode_) on_decode_(stats_);
    decoded_.notify_all();
}

void HtChunkCache::evict_over_budget(std::size_t keep) {
    // Oldest first; a chunk a reader still holds stays (the budget yields).
    for (auto it = lru_.end(); bytes_ > budget_ && it != lru_.begin();) {
        --it;
        const std::size_t id = *it;
        Slot& s = slots_[id];
        if (id == keep || s.chunk.use_count() > 1) continue;
        bytes_ -= s.chunk->bytes();
        s.chunk.reset();
        it = lru_.erase(it);
    }
}

std::shared_ptr<const DecodedChunk> HtChunkCache::decode_uncached(std::size_t id, bool errors) {
    Prepared p;
    {
        std::unique_lock<std::mutex> lock(mu_);
        Pins pins;  // the coarser chunks it fetches stay pinned while it copies from them
        p = prepare(id, errors, lock, pins);
        pins.clear();
        evict_over_budget(SIZE_MAX);
        stats_.decodes += 1;
        stats_.distinct += slots_[id].seen ? 0 : 1;
        slots_[id].seen = true;
    }
    finish(id, p);
    return p.chunk;
}

void HtChunkCache::finish(std::size_t id, Prepared& p) {
    const HtChunk& c = L_.chunks[id];
    DecodedChunk& out = *p.chunk;
    const Failure f = decode_chunk_sections(r_, L_, c, out.window, out.type, out.field.data(),
                                            out.errors.empty() ? nullptr : out.errors.data(), p.field_stored,
                                            p.error_stored);
    if (f.code != ErrorCode::Ok) raise(f);
}

HtChunkCache::Prepared HtChunkCache::prepare(std::size_t id, bool errors, std::unique_lock<std::mutex>& lock,
                                             Pins& pins) {
    const HtChunk& c = L_.chunks[id];
    const int t = c.cycle;
    auto out = std::make_shared<DecodedChunk>();
    int64_t n = 0;
    out->window = window_for(G_, t, c.box, &n);
    out->type = L_.metadata.type;
    const std::size_t vs = value_size(out->type);
    const Geometry& W = out->window;
    out->field.assign(std::size_t(n) * vs, std::byte{0});
    if (errors) out->errors.assign(std::size_t(n), 0.0f);
    const int64_t h = int64_t{1} << t;
    // The window's extent in grid coordinates.
    std::array<int64_t, 6> wb{};
    const int64_t nz = W.nx > 0 && W.ny > 0 ? n / (W.nx * W.ny) : 0;
    const int64_t wn[3] = {W.nx, W.ny, nz};
    for (int a = 0; a < 3; ++a) {
        wb[a] = W.origin[a];
        wb[3 + a] = W.origin[a] + (wn[a] - 1) * h;
    }
    // Coarser points: copied from the chunks of cycles t+1..k meeting the window.
    for (int tc = t + 1; tc <= G_.k; ++tc) {
        const auto nb = G_.bricks(tc);
        const int64_t side = G_.side(tc);
        int64_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min<int64_t>(wb[a] / side, nb[a] - 1);
            hi[a] = std::min<int64_t>(wb[3 + a] / side, nb[a] - 1);
        }
        for (int64_t bz = lo[2]; bz <= hi[2]; ++bz)
            for (int64_t by = lo[1]; by <= hi[1]; ++by)
                for (int64_t bx = lo[0]; bx <= hi[0]; ++bx) {
                    const std::size_t did =
                        first_of_cycle_[std::size_t(tc)] + std::size_t((bz * nb[1] + by) * nb[0] + bx);
                    const HtChunk& d = L_.chunks[did];
                    std::array<int64_t, 6> isect{};
                    bool empty = false;
                    for (int a = 0; a < 3; ++a) {
                        isect[a] = std::max(d.box[a], wb[a]);
                        isect[3 + a] = std::min(d.box[3 + a], wb[3 + a]);
                        empty = empty || isect[a] > isect[3 + a];
                    }
                    if (empty || G_.count_points(tc, isect) == 0) continue;
                    auto dep = get_locked(did, lock, pins);
                    const Geometry& D = dep->window;
                    const std::byte* src = dep->field.data();
                    std::byte* dst = out->field.data();
                    // By rows, with the value size fixed: point by point (two
                    // index computations and a memcpy of vs bytes each) this was
                    // 2.5% of a 257^3 decode, under the cache's lock.
                    G_.for_each_row(tc, isect, [&](int64_t x0, int64_t x1, int64_t step, int64_t y, int64_t z) {
                        copy_row(dst + std::size_t(W.index(x0, y, z)) * vs, W.index_delta(step, 0, 0),
                                 src + std::size_t(D.index(x0, y, z)) * vs, D.index_delta(step, 0, 0),
                                 (x1 - x0) / step + 1, vs);
                    });
                }
    }
    Prepared p;
    auto fst = r_.read_stored(c.field_section);
    if (!fst) raise(fst.failure());
    p.field_stored = std::move(*fst);
    if (errors) {
        auto est = r_.read_stored(c.error_section);
        if (!est) raise(est.failure());
        p.error_stored = std::move(*est);
    }
    p.chunk = std::move(out);
    return p;
}

CachedSampleSource::CachedSampleSource(HtChunkCache& cache)
    : cache_(cache), memo_(std::size_t(cache.layout().domain.k + 1)) {}

const DecodedChunk& CachedSampleSource::at(const Point& p) {
    int t = 0;
    const std::size_t id = cache_.chunk_of(p, &t);
    Memo& m = memo_[std::size_t(t)];
    if (m.id != id) {
        m.chunk.reset();  // let the cache evict it while we fetch
        m.id = SIZE_MAX;
        m.chunk = cache_.get(id);
        m.id = id;
    }
    return *m.chunk;
}

float CachedSampleSource::error(const Point& p) {
    const DecodedChunk& c = at(p);
    return c.errors[std::size_t(c.window.index(p[0], p[1], p[2]))];
}

float CachedSampleSource::field_error_bound() {
    // E rounded up to float, as HtModel::from_parts states it for a decoded model.
    return float_at_least(cache_.layout().max_error);
}

double CachedSampleSource::value(const Point& p) {
    const DecodedChunk& c = at(p);
    const std::size_t i = std::size_t(c.window.index(p[0], p[1], p[2]));
    return dispatch_value_type(c.type, [&](auto tag) {
        using T = decltype(tag);
        T v;
        std::memcpy(&v, c.field.data() + i * sizeof(T), sizeof(T));
        return double(v);
    });
}

void CachedSampleSource::prefetch(const Point* points, int count) {
    for (int i = 0; i < count; ++i) {
        const std::size_t id = cache_.chunk_of(points[i]);
        if (id == last_prefetch_) continue;
        last_prefetch_ = id;
        cache_.prefetch(id);
    }
}

std::unique_ptr<HtSampleSource> CachedSampleSource::fork() { return std::make_unique<CachedSampleSource>(cache_); }

}  // namespace tetlod::ht_detail
