#pragma once
// A map from HT grid points to 31-bit values, sized by what is inserted, with
// the locality of a dense array: the refinement's split set and vertex
// numbering when the grid is not in memory.
//
// A point of cycle t (t = trailing zeros of x | y | z) lives on the lattice of
// spacing 2^t. That lattice is cut into blocks of 4 x 4 x 4 of its points; a
// block is a small dense array, allocated when its first point is inserted and
// found through a hash table per cycle (PointIdMap, keyed by block). The
// refinement and the tree walks visit neighbouring points one after the other,
// so consecutive lookups fall in the same few blocks and the per-cycle tables
// (64 times fewer entries than points when blocks are full) stay in cache,
// where one hash table over every point costs a cache miss per lookup.
// Memory: 256 bytes per block touched, so about 4 to 40 bytes per point when
// the points of a cycle are clustered (a LOD refines regions, not isolated
// points) and at most 256 bytes per point when they are scattered.
#include <bit>
#include <cstdint>
#include <memory>
#include <vector>

#include "tetlod/models/detail/point_id_map.hpp"

namespace tetlod::detail {

class BlockedPointMap {
public:
    using Point = PointIdMap::Point;

    /// `max_coordinate`: the largest coordinate any point will have.
    explicit BlockedPointMap(int64_t max_coordinate = (int64_t{1} << 20))
        : cycles_(std::size_t(std::bit_width(uint64_t(std::max<int64_t>(max_coordinate, 1))) + 1)) {
        for (std::size_t t = 0; t < cycles_.size(); ++t)
            cycles_[t].blocks = PointIdMap(std::max<int64_t>(max_coordinate >> (t + kBlockLog2), 1));
    }

    std::size_t size() const { return size_; }

    /// The value stored at p, or false.
    bool find(const Point& p, uint32_t& value) const {
        const Where w = where(p);
        uint32_t b;
        if (!cycles_[w.cycle].blocks.find(w.block, b)) return false;
        const uint32_t v = slot(b, w.offset);
        if (v == 0) return false;
        value = v - 1;
        return true;
    }

    /// Stores v (< 2^32 - 1) at p, replacing a previous value.
    void put(const Point& p, uint32_t v) {
        const Where w = where(p);
        PointIdMap& blocks = cycles_[w.cycle].blocks;
        uint32_t b;
        if (!blocks.find(w.block, b)) {
            b = block_count_++;
            blocks.put(w.block, b);
            if ((b & (kPageBlocks - 1)) == 0) pages_.push_back(std::make_unique<uint32_t[]>(kPageBlocks * kBlockPoints));
        }
        uint32_t& s = slot(b, w.offset);
        size_ += s == 0;
        s = v + 1;
    }

    std::size_t memory_bytes() const {
        std::size_t n = pages_.size() * kPageBlocks * kBlockPoints * sizeof(uint32_t);
        for (const auto& c : cycles_) n += c.blocks.memory_bytes();
        return n;
    }

private:
    static constexpr int kBlockLog2 = 2;  // 4 lattice points per axis
    static constexpr std::size_t kBlockPoints = std::size_t{1} << (3 * kBlockLog2);
    // Blocks are allocated in pages of this many (256 KiB): no reallocation,
    // so no copy and no doubled peak as the map grows.
    static constexpr uint32_t kPageBlocks = 1024;

    uint32_t& slot(uint32_t b, std::size_t offset) const {
        return pages_[b / kPageBlocks][std::size_t(b & (kPageBlocks - 1)) * kBlockPoints + offset];
    }

    struct Where {
        std::size_t cycle;
        Point block;
        std::size_t offset;
    };
    static Where where(const Point& p) {
        const uint32_t any = uint32_t(p[0]) | uint32_t(p[1]) | uint32_t(p[2]);
        // The origin belongs to no cycle; filing it under cycle 0 is unambiguous
        // (a cycle's lattice coordinates identify the point).
        const int t = any == 0 ? 0 : std::countr_zero(any);
        constexpr uint32_t m = (1u << kBlockLog2) - 1;
        const uint32_t l[3] = {uint32_t(p[0]) >> t, uint32_t(p[1]) >> t, uint32_t(p[2]) >> t};
        return Where{std::size_t(t),
                     Point{int32_t(l[0] >> kBlockLog2), int32_t(l[1] >> kBlockLog2), int32_t(l[2] >> kBlockLog2)},
                     std::size_t(((l[2] & m) << (2 * kBlockLog2)) | ((l[1] & m) << kBlockLog2) | (l[0] & m))};
    }

    struct Cycle {
        PointIdMap blocks;  // block -> index of its block
    };
    std::vector<Cycle> cycles_;
    // Per block, per point: value + 1 (0: absent); make_unique zero-fills.
    std::vector<std::unique_ptr<uint32_t[]>> pages_;
    uint32_t block_count_ = 0;
    std::size_t size_ = 0;
};

}  // namespace tetlod::detail
