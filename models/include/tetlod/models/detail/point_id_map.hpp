#pragma once
// A map from lattice points to 32-bit values, sized by what is inserted:
// open addressing with linear probing over 64-bit packed coordinates. The
// refinement's split set and vertex numbering live in one, so their memory
// follows the output mesh, not the grid.
#include <array>
#include <bit>
#include <cstdint>
#include <vector>

namespace tetlod::detail {

class PointIdMap {
public:
    using Point = std::array<int32_t, 3>;

    /// 21 bits per coordinate (axes are at most 2^20 + 1 points); +1 so that 0 marks an empty slot.
    static uint64_t key(const Point& p) {
        return ((uint64_t(uint32_t(p[0])) << 42) | (uint64_t(uint32_t(p[1])) << 21) | uint64_t(uint32_t(p[2]))) + 1;
    }

    std::size_t size() const { return size_; }

    /// The value stored at p, or nullptr.
    const uint32_t* find(const Point& p) const {
        if (size_ == 0) return nullptr;
        const uint64_t k = key(p);
        for (std::size_t i = slot(k);; i = (i + 1) & mask_) {
            if (keys_[i] == k) return &values_[i];
            if (keys_[i] == 0) return nullptr;
        }
    }

    /// Stores v at p (replacing a previous value).
    void put(const Point& p, uint32_t v) {
        // Grow at 70% load: linear probing stays short (a miss costs about
        // 6 probes at 0.7) and the table takes 17-34 bytes per entry.
        if (10 * (size_ + 1) > 7 * keys_.size()) grow();
        const uint64_t k = key(p);
        std::size_t i = slot(k);
        while (keys_[i] != 0 && keys_[i] != k) i = (i + 1) & mask_;
        if (keys_[i] == 0) ++size_;
        keys_[i] = k;
        values_[i] = v;
    }

    std::size_t memory_bytes() const { return keys_.capacity() * 8 + values_.capacity() * 4; }

private:
    std::size_t slot(uint64_t k) const { return std::size_t((k * 0x9E3779B97F4A7C15ull) >> shift_); }

    void grow() {
        std::vector<uint64_t> old_keys = std::move(keys_);
        std::vector<uint32_t> old_values = std::move(values_);
        const std::size_t cap = old_keys.empty() ? 1024 : old_keys.size() * 2;
        keys_.assign(cap, 0);
        values_.assign(cap, 0);
        mask_ = cap - 1;
        shift_ = 64 - std::countr_zero(cap);
        for (std::size_t j = 0; j < old_keys.size(); ++j) {
            if (old_keys[j] == 0) continue;
            std::size_t i = slot(old_keys[j]);
            while (keys_[i] != 0) i = (i + 1) & mask_;
            keys_[i] = old_keys[j];
            values_[i] = old_values[j];
        }
    }

    std::vector<uint64_t> keys_;
    std::vector<uint32_t> values_;
    std::size_t size_ = 0, mask_ = 0;
    int shift_ = 64;
};

}  // namespace tetlod::detail
