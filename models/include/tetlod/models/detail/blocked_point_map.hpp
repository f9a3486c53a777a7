#pragma once
// A map from HT grid points to 31-bit values, sized by what is inserted, with
// the locality of a dense array and safe for concurrent writers: the
// refinement's split set and vertex numbering when the grid is not in memory.
//
// A point of cycle t (t = trailing zeros of x | y | z) lives on the lattice of
// spacing 2^t. That lattice is cut into blocks of 4 x 4 x 4 of its points and
// blocks into leaves of 8 x 8 x 8 blocks. A block is a small dense array of
// slots; a leaf holds the indices of its blocks; one open-addressing table
// (over every cycle) finds the leaf. The refinement and the tree walks visit
// neighbouring points one after the other, so consecutive lookups fall in the
// same few blocks and leaves, and the table (32768 times fewer entries than
// lattice points) stays in cache.
//
// Concurrency: find, put and set_bit0 may run at once from any number of
// threads. Leaves, blocks and pages are created with compare-and-swap and
// never move, so a reader never takes a lock. The table does not grow: it is
// sized from the largest coordinate to hold every leaf a grid can have (at
// most 2^22 entries, virtual memory touched only where used).
//
// Memory: 256 bytes per block touched, so about 4 to 40 bytes per point when
// the points of a cycle are clustered (a LOD refines regions, not isolated
// points) and at most 256 bytes per point (plus 2 KiB per leaf) when they are
// scattered.
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <stdexcept>

namespace tetlod::detail {

class BlockedPointMap {
public:
    using Point = std::array<int32_t, 3>;

    /// `max_coordinate`: the largest coordinate any point will have (< 2^24).
    explicit BlockedPointMap(int64_t max_coordinate = (int64_t{1} << 20)) {
        max_coordinate = std::max<int64_t>(max_coordinate, 1);
        if (max_coordinate >= (int64_t{1} << 24)) throw std::length_error("BlockedPointMap: coordinates of 2^24 or more");
        // Every leaf the grid can have, over all cycles; the table twice that
        // (load at most one half) within [64, 2^22].
        uint64_t leaves = 0;
        for (int t = 0; (max_coordinate >> t) > 0 || t == 0; ++t) {
            const uint64_t n = uint64_t(((max_coordinate >> t) + 1 + kLeafSide - 1) / kLeafSide);
            leaves += n * n * n;
            if (leaves > (uint64_t{1} << 22)) break;
        }
        capacity_ = std::bit_ceil(std::clamp<uint64_t>(2 * leaves, 64, uint64_t{1} << 22));
        capacity_log2_ = std::countr_zero(capacity_);
        keys_ = calloc_array<uint64_t>(capacity_);
        leaves_ = calloc_array<uint32_t*>(capacity_);
        // A leaf's blocks are at most kLeafBlocks, and half the table at most is used.
        max_pages_ = std::min<uint64_t>(capacity_ / 2 * kLeafBlocks / kPageBlocks + 1, uint64_t{1} << 22);
        pages_ = calloc_array<Page*>(max_pages_);
    }
    BlockedPointMap(const BlockedPointMap&) = delete;
    BlockedPointMap& operator=(const BlockedPointMap&) = delete;
    ~BlockedPointMap() {
        for (uint64_t i = 0; i < capacity_; ++i) std::free(leaves_[i]);
        for (uint64_t i = 0; i < max_pages_; ++i) std::free(pages_[i]);
        std::free(keys_);
        std::free(leaves_);
        std::free(pages_);
    }

    /// The value stored at p, or false.
    bool find(const Point& p, uint32_t& value) const {
        const Where w = where(p);
        const uint32_t* leaf = find_leaf(w.leaf_key);
        if (!leaf) return false;
        const uint32_t b = load(leaf[w.block_in_leaf]);
        if (b == 0) return false;
        const uint32_t v = load(slot(b - 1, w.offset));
        if (v == 0) return false;
        value = v - 1;
        return true;
    }

    /// Stores v (< 2^32 - 1) at p, replacing a previous value.
    void put(const Point& p, uint32_t v) { std::atomic_ref<uint32_t>(slot_for(p)).store(v + 1, std::memory_order_release); }

    /// Sets bit 0 of the value at p (the value 1 if p is absent). True if this
    /// call set it: of threads racing on one point, exactly one wins.
    bool set_bit0(const Point& p) {
        std::atomic_ref<uint32_t> s(slot_for(p));
        uint32_t old = s.load(std::memory_order_acquire);
        for (;;) {
            if (old != 0 && ((old - 1) & 1u)) return false;
            const uint32_t want = ((old == 0 ? 0u : old - 1) | 1u) + 1;
            if (s.compare_exchange_weak(old, want, std::memory_order_acq_rel, std::memory_order_acquire)) return true;
        }
    }

    /// Blocks created so far; for_each_in_block visits one. Not concurrent with writers.
    uint32_t block_count() const { return std::min(block_count_.load(), uint32_t(max_pages_ * kPageBlocks)); }

    /// f(point, value) for every point stored in block b.
    template <class F>
    void for_each_in_block(uint32_t b, F&& f) const {
        const Page* page = pages_[b / kPageBlocks];
        if (!page) return;
        const BlockKey& k = page->key[b % kPageBlocks];
        const uint32_t* s = page->slot + std::size_t(b % kPageBlocks) * kBlockPoints;
        for (uint32_t o = 0; o < kBlockPoints; ++o) {
            if (s[o] == 0) continue;
            const int32_t l[3] = {int32_t(o & 3), int32_t((o >> 2) & 3), int32_t(o >> 4)};
            f(Point{(k.base[0] + l[0]) << k.cycle, (k.base[1] + l[1]) << k.cycle, (k.base[2] + l[2]) << k.cycle},
              s[o] - 1);
        }
    }

    /// f(point, value) for every point stored. Not concurrent with writers.
    template <class F>
    void for_each(F&& f) const {
        for (uint32_t b = 0; b < block_count(); ++b) for_each_in_block(b, f);
    }

    /// Points stored (a walk over the blocks).
    std::size_t size() const {
        std::size_t n = 0;
        for_each([&](const Point&, uint32_t) { ++n; });
        return n;
    }

    std::size_t memory_bytes() const {
        const uint64_t blocks = block_count();
        return std::size_t(capacity_ * (sizeof(uint64_t) + sizeof(uint32_t*)) + max_pages_ * sizeof(Page*) +
                           leaf_count_.load() * kLeafBlocks * sizeof(uint32_t) +
                           (blocks + kPageBlocks - 1) / kPageBlocks * sizeof(Page));
    }

private:
    static constexpr int kBlockLog2 = 2;  // 4 lattice points per axis
    static constexpr uint32_t kBlockPoints = 1u << (3 * kBlockLog2);
    static constexpr int kLeafLog2 = 3;  // 8 blocks per axis
    static constexpr uint32_t kLeafBlocks = 1u << (3 * kLeafLog2);
    static constexpr int64_t kLeafSide = int64_t{1} << (kBlockLog2 + kLeafLog2);  // lattice points
    // Blocks are allocated in pages of this many (256 KiB of slots): no
    // reallocation, so no copy and no doubled peak as the map grows.
    static constexpr uint32_t kPageBlocks = 1024;

    struct BlockKey {
        int32_t base[3];  // lattice coordinates of the block's first point
        int32_t cycle;
    };
    struct Page {
        uint32_t slot[kPageBlocks * kBlockPoints];  // value + 1 (0: absent)
        BlockKey key[kPageBlocks];
    };

    template <class T>
    static T* calloc_array(uint64_t n) {
        void* p = std::calloc(std::size_t(n), sizeof(T));
        if (!p) throw std::bad_alloc();
        return static_cast<T*>(p);
    }
    template <class T>
    static T load(const T& v) {
        return std::atomic_ref<T>(const_cast<T&>(v)).load(std::memory_order_acquire);
    }

    struct Where {
        uint64_t leaf_key;  // + 1, never 0
        uint32_t block_in_leaf;
        uint32_t offset;
        int32_t cycle;
        int32_t block_base[3];
    };
    static Where where(const Point& p) {
        const uint32_t any = uint32_t(p[0]) | uint32_t(p[1]) | uint32_t(p[2]);
        // The origin belongs to no cycle; filing it under cycle 0 is unambiguous
        // (a cycle's lattice coordinates identify the point).
        const int t = any == 0 ? 0 : std::countr_zero(any);
        const uint32_t l[3] = {uint32_t(p[0]) >> t, uint32_t(p[1]) >> t, uint32_t(p[2]) >> t};
        constexpr uint32_t bm = (1u << kBlockLog2) - 1, lm = (1u << kLeafLog2) - 1;
        constexpr int ls = kBlockLog2 + kLeafLog2;
        Where w;
        w.cycle = t;
        w.leaf_key = ((uint64_t(t) << 57) | (uint64_t(l[0] >> ls) << 38) | (uint64_t(l[1] >> ls) << 19) |
                      uint64_t(l[2] >> ls)) + 1;
        w.block_in_leaf = (((l[2] >> kBlockLog2) & lm) << (2 * kLeafLog2)) |
                          (((l[1] >> kBlockLog2) & lm) << kLeafLog2) | ((l[0] >> kBlockLog2) & lm);
        w.offset = ((l[2] & bm) << (2 * kBlockLog2)) | ((l[1] & bm) << kBlockLog2) | (l[0] & bm);
        for (int a = 0; a < 3; ++a) w.block_base[a] = int32_t(l[a] & ~bm);
        return w;
    }

    /// Fibonacci hashing: the top bits of the product, which every key bit reaches.
    uint64_t home(uint64_t key) const { return (key * 0x9E3779B97F4A7C15ull) >> (64 - capacity_log2_); }

    const uint32_t* find_leaf(uint64_t key) const {
        for (uint64_t i = home(key), n = 0; n < capacity_; i = (i + 1) & (capacity_ - 1), ++n) {
            const uint64_t k = load(keys_[i]);
            if (k == key) return load(leaves_[i]);  // null while its creator allocates it: nothing stored yet
            if (k == 0) return nullptr;
        }
        return nullptr;
    }

    uint32_t* leaf_for(uint64_t key) {
        for (uint64_t i = home(key), n = 0; n < capacity_; i = (i + 1) & (capacity_ - 1), ++n) {
            std::atomic_ref<uint64_t> k(keys_[i]);
            uint64_t seen = k.load(std::memory_order_acquire);
            if (seen == 0) {
                if (k.compare_exchange_strong(seen, key, std::memory_order_acq_rel)) {
                    auto* leaf = calloc_array<uint32_t>(kLeafBlocks);
                    leaf_count_.fetch_add(1, std::memory_order_relaxed);
                    std::atomic_ref<uint32_t*>(leaves_[i]).store(leaf, std::memory_order_release);
                    return leaf;
                }
            }
            if (seen == key) {
                std::atomic_ref<uint32_t*> l(leaves_[i]);
                uint32_t* leaf;
                while (!(leaf = l.load(std::memory_order_acquire))) {}  // its creator is allocating it
                return leaf;
            }
        }
        throw std::length_error("BlockedPointMap: too many scattered points for its table");
    }

    uint32_t& slot(uint32_t b, uint32_t offset) const {
        return pages_[b / kPageBlocks]->slot[std::size_t(b % kPageBlocks) * kBlockPoints + offset];
    }

    uint32_t& slot_for(const Point& p) {
        const Where w = where(p);
        uint32_t* leaf = leaf_for(w.leaf_key);
        std::atomic_ref<uint32_t> entry(leaf[w.block_in_leaf]);
        uint32_t b1 = entry.load(std::memory_order_acquire);
        if (b1 == 0) {
            const uint32_t b = block_count_.fetch_add(1, std::memory_order_relaxed);
            if (b / kPageBlocks >= max_pages_) throw std::length_error("BlockedPointMap: too many blocks");
            std::atomic_ref<Page*> page(pages_[b / kPageBlocks]);
            if (!page.load(std::memory_order_acquire)) {
                Page* fresh = calloc_array<Page>(1);
                Page* expected = nullptr;
                if (!page.compare_exchange_strong(expected, fresh, std::memory_order_acq_rel)) std::free(fresh);
            }
            BlockKey& key = page.load(std::memory_order_acquire)->key[b % kPageBlocks];
            key = BlockKey{{w.block_base[0], w.block_base[1], w.block_base[2]}, w.cycle};
            // A lost race leaves block b empty (never visited: no slot is set).
            if (entry.compare_exchange_strong(b1, b + 1, std::memory_order_acq_rel)) b1 = b + 1;
        }
        return slot(b1 - 1, w.offset);
    }

    uint64_t capacity_ = 0, max_pages_ = 0;
    int capacity_log2_ = 6;
    uint64_t* keys_ = nullptr;      // leaf key + 1 (0: free), per table entry
    uint32_t** leaves_ = nullptr;   // per table entry: block index + 1 per block of the leaf
    Page** pages_ = nullptr;
    std::atomic<uint32_t> block_count_{0};
    std::atomic<uint64_t> leaf_count_{0};
};

}  // namespace tetlod::detail
