#pragma once
// A map from lattice points to 31-bit values, sized by what is inserted:
// open addressing with linear probing. The refinement's split set and vertex
// numbering live in one, so their memory follows the output mesh, not the grid.
//
// Two layouts. Packed: one 64-bit word per slot, the coordinates in 3b bits
// (b bits per axis, from the largest coordinate) and the value in the rest;
// 8 bytes per slot. Wide: a 64-bit key and a 32-bit value, 12 bytes per slot,
// for large coordinates or a value that outgrows the packed field (the table
// switches once, keeping its content).
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <vector>

namespace tetlod::detail {

class PointIdMap {
public:
    using Point = std::array<int32_t, 3>;

    /// `max_coordinate`: the largest coordinate any point will have.
    explicit PointIdMap(int64_t max_coordinate = (int64_t{1} << 20)) {
        // max_coordinate < 2^b - 1, so key + 1 never overflows its 3b bits.
        bits_ = std::max(2, int(std::bit_width(uint64_t(max_coordinate))) + 1);
        wide_ = 3 * bits_ > 52;  // a packed value field under 12 bits is not worth it
        value_bits_ = wide_ ? 32 : 64 - 3 * bits_;
    }

    std::size_t size() const { return size_; }

    /// The value stored at p, or false.
    bool find(const Point& p, uint32_t& value) const {
        if (size_ == 0) return false;
        if (!wide_) {
            const uint64_t k = packed_key(p);
            for (std::size_t i = slot(k);; i = (i + 1) & mask_) {
                const uint64_t w = words_[i];
                if (w == 0) return false;
                if ((w >> value_bits_) == k) {
                    value = uint32_t(w & ((uint64_t{1} << value_bits_) - 1));
                    return true;
                }
            }
        }
        const uint64_t k = wide_key(p);
        for (std::size_t i = slot(k);; i = (i + 1) & mask_) {
            if (keys_[i] == k) {
                value = values_[i];
                return true;
            }
            if (keys_[i] == 0) return false;
        }
    }

    /// Stores v at p (replacing a previous value).
    void put(const Point& p, uint32_t v) {
        if (!wide_ && value_bits_ < 32 && (uint64_t(v) >> value_bits_) != 0) widen();
        // Grow at 70% load: linear probing stays short (a miss costs about
        // 6 probes at 0.7).
        if (10 * (size_ + 1) > 7 * capacity()) grow();
        insert(p, v);
    }

    std::size_t memory_bytes() const { return words_.capacity() * 8 + keys_.capacity() * 8 + values_.capacity() * 4; }
    bool packed() const { return !wide_; }

private:
    uint64_t packed_key(const Point& p) const {
        return ((uint64_t(uint32_t(p[0])) << (2 * bits_)) | (uint64_t(uint32_t(p[1])) << bits_) | uint64_t(uint32_t(p[2]))) + 1;
    }
    /// 21 bits per coordinate (axes are at most 2^20 + 1 points); +1 so that 0 marks an empty slot.
    static uint64_t wide_key(const Point& p) {
        return ((uint64_t(uint32_t(p[0])) << 42) | (uint64_t(uint32_t(p[1])) << 21) | uint64_t(uint32_t(p[2]))) + 1;
    }
    Point unpack(uint64_t k) const {
        k -= 1;
        const uint64_t m = (uint64_t{1} << bits_) - 1;
        return Point{int32_t((k >> (2 * bits_)) & m), int32_t((k >> bits_) & m), int32_t(k & m)};
    }
    std::size_t slot(uint64_t k) const { return std::size_t((k * 0x9E3779B97F4A7C15ull) >> shift_); }
    std::size_t capacity() const { return wide_ ? keys_.size() : words_.size(); }

    void insert(const Point& p, uint32_t v) {
        if (!wide_) {
            const uint64_t k = packed_key(p);
            std::size_t i = slot(k);
            while (words_[i] != 0 && (words_[i] >> value_bits_) != k) i = (i + 1) & mask_;
            if (words_[i] == 0) ++size_;
            words_[i] = (k << value_bits_) | v;
            return;
        }
        const uint64_t k = wide_key(p);
        std::size_t i = slot(k);
        while (keys_[i] != 0 && keys_[i] != k) i = (i + 1) & mask_;
        if (keys_[i] == 0) ++size_;
        keys_[i] = k;
        values_[i] = v;
    }

    /// Every entry, as (point, value).
    template <class F> void for_each(F&& f) const {
        if (!wide_) {
            for (uint64_t w : words_)
                if (w != 0) f(unpack(w >> value_bits_), uint32_t(w & ((uint64_t{1} << value_bits_) - 1)));
            return;
        }
        for (std::size_t j = 0; j < keys_.size(); ++j)
            if (keys_[j] != 0) {
                const uint64_t k = keys_[j] - 1;
                f(Point{int32_t(k >> 42), int32_t((k >> 21) & 0x1FFFFF), int32_t(k & 0x1FFFFF)}, values_[j]);
            }
    }

    void rebuild(std::size_t cap, bool wide) {
        PointIdMap old = std::move(*this);
        *this = PointIdMap();
        bits_ = old.bits_;
        value_bits_ = old.value_bits_;
        wide_ = wide;
        if (wide_) {
            keys_.assign(cap, 0);
            values_.assign(cap, 0);
        } else {
            words_.assign(cap, 0);
        }
        mask_ = cap - 1;
        shift_ = 64 - std::countr_zero(cap);
        old.for_each([&](const Point& p, uint32_t v) { insert(p, v); });
    }
    void grow() { rebuild(capacity() == 0 ? 1024 : capacity() * 2, wide_); }
    void widen() { rebuild(capacity() == 0 ? 1024 : capacity(), true); }

    std::vector<uint64_t> words_;  // packed
    std::vector<uint64_t> keys_;   // wide
    std::vector<uint32_t> values_;
    std::size_t size_ = 0, mask_ = 0;
    int shift_ = 64;
    int bits_ = 21, value_bits_ = 1;
    bool wide_ = true;
};

}  // namespace tetlod::detail
