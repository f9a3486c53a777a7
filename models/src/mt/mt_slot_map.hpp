#pragma once
// Grid index -> slot of a vertex present in an MT extraction. Open addressing with
// linear probing over a power-of-two table kept at most half full, so memory and time
// follow the vertices a query touches, not the grid points of the volume (a dense
// per-grid-point array would cost 4 bytes per point for every query).
#include <cstdint>
#include <vector>

namespace tetlod::mt {

class SlotMap {
public:
    static constexpr uint32_t kAbsent = 0xFFFFFFFFu;

    explicit SlotMap(size_t expected = 64) { rehash(capacity_for(expected)); }

    /// Slot of grid index `key`, or kAbsent.
    uint32_t find(uint32_t key) const {
        for (size_t i = hash(key);; i = (i + 1) & mask_) {
            const Entry& e = table_[i];
            if (e.key == key) return e.slot;
            if (e.key == kEmpty) return kAbsent;
        }
    }
    /// Records key -> slot; key must be absent.
    void insert(uint32_t key, uint32_t slot) {
        if (2 * (size_ + 1) > table_.size()) rehash(2 * table_.size());
        place(key, slot);
        ++size_;
    }
    size_t size() const { return size_; }

private:
    static constexpr uint32_t kEmpty = 0xFFFFFFFFu;  // no grid index reaches it (< 2^31 points)
    struct Entry {
        uint32_t key = kEmpty, slot = 0;
    };

    static size_t capacity_for(size_t n) {
        size_t c = 16;
        while (c < 2 * n) c *= 2;
        return c;
    }
    size_t hash(uint32_t key) const {
        // Fibonacci hashing: neighbouring grid indices spread over the table.
        return size_t((uint64_t(key) * 0x9E3779B97F4A7C15ull) >> 32) & mask_;
    }
    void place(uint32_t key, uint32_t slot) {
        size_t i = hash(key);
        while (table_[i].key != kEmpty) i = (i + 1) & mask_;
        table_[i] = {key, slot};
    }
    void rehash(size_t capacity) {
        std::vector<Entry> old = std::move(table_);
        table_.assign(capacity, Entry{});
        mask_ = capacity - 1;
        for (const Entry& e : old)
            if (e.key != kEmpty) place(e.key, e.slot);
    }

    std::vector<Entry> table_;
    size_t mask_ = 0;
    size_t size_ = 0;
};

}  // namespace tetlod::mt
