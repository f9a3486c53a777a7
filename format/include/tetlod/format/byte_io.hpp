#pragma once
// Little-endian field access for the .tlod container (spec/tlod-format.md §2:
// every multi-byte integer and float is little-endian). ByteReader is the only
// way the decoders look at untrusted bytes: every read is bounds-checked and a
// short read latches a failure instead of reading past the end.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace tetlod::tlod {

inline void put_u8(std::vector<std::byte>& out, uint8_t v) { out.push_back(std::byte{v}); }
inline void put_le(std::vector<std::byte>& out, uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) out.push_back(std::byte(static_cast<uint8_t>(v >> (8 * i))));
}
inline void put_u16(std::vector<std::byte>& out, uint16_t v) { put_le(out, v, 2); }
inline void put_u32(std::vector<std::byte>& out, uint32_t v) { put_le(out, v, 4); }
inline void put_u64(std::vector<std::byte>& out, uint64_t v) { put_le(out, v, 8); }
inline void put_f64(std::vector<std::byte>& out, double v) {
    uint64_t b;
    std::memcpy(&b, &v, 8);
    put_u64(out, b);
}
inline void put_bytes(std::vector<std::byte>& out, std::string_view s) {
    const auto* p = reinterpret_cast<const std::byte*>(s.data());
    out.insert(out.end(), p, p + s.size());
}

inline uint64_t load_le(const std::byte* p, int bytes) {
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= uint64_t(std::to_integer<uint8_t>(p[i])) << (8 * i);
    return v;
}
inline void store_le(std::byte* p, uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) p[i] = std::byte(static_cast<uint8_t>(v >> (8 * i)));
}

/// Sequential bounds-checked reader over untrusted bytes. After the first short
/// read every further read returns zeros and ok() stays false.
class ByteReader {
public:
    explicit ByteReader(std::span<const std::byte> data) : data_(data) {}
    bool ok() const { return ok_; }
    std::size_t remaining() const { return ok_ ? data_.size() - pos_ : 0; }
    std::size_t position() const { return pos_; }
    bool at_end() const { return ok_ && pos_ == data_.size(); }

    uint64_t le(int bytes) {
        if (!take(static_cast<std::size_t>(bytes))) return 0;
        return load_le(data_.data() + pos_ - bytes, bytes);
    }
    uint8_t u8() { return static_cast<uint8_t>(le(1)); }
    uint16_t u16() { return static_cast<uint16_t>(le(2)); }
    uint32_t u32() { return static_cast<uint32_t>(le(4)); }
    uint64_t u64() { return le(8); }
    double f64() {
        uint64_t b = u64();
        double v;
        std::memcpy(&v, &b, 8);
        return v;
    }
    /// Reads n bytes as a string (empty and !ok() when fewer remain).
    std::string str(std::size_t n) {
        if (!take(n)) return {};
        return std::string(reinterpret_cast<const char*>(data_.data() + pos_ - n), n);
    }

private:
    bool take(std::size_t n) {
        if (!ok_ || n > data_.size() - pos_) {
            ok_ = false;
            return false;
        }
        pos_ += n;
        return true;
    }
    std::span<const std::byte> data_;
    std::size_t pos_ = 0;
    bool ok_ = true;
};

}  // namespace tetlod::tlod
