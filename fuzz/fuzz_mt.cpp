// libFuzzer target: the MT decoder (docs/mt.md §5) on arbitrary bytes. The first
// byte picks the mode: even, the rest is an encode_mt byte string as stored; odd,
// the rest is a 48-byte MT header and the *raw* payload (streams as u64 length +
// bytes), which the harness compresses itself as the header's coding says (coding
// 1: one frame; otherwise a frame per stream, coding 2) and fixes the two size
// fields, so mutations reach the stream parser behind the zstd frames. Accepted
// models are extracted and their stored errors checked (check_mt_bounds, what
// verify --deep runs); either may refuse with CorruptData, never crash.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "tetlod/analysis/mt_bound_check.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/format/container.hpp"

using namespace tetlod;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    std::vector<uint8_t> bytes(data + 1, data + size);
    if ((data[0] & 1) && bytes.size() >= 48) {
        std::span<const std::byte> raw(reinterpret_cast<const std::byte*>(bytes.data() + 48), bytes.size() - 48);
        const bool one_frame = bytes[4] == 1 && bytes[5] == 0;
        std::vector<uint8_t> payload;
        uint64_t rs = raw.size();
        if (one_frame) {
            const std::vector<std::byte> z = tlod::zstd_compress(raw, 1);
            const auto* zb = reinterpret_cast<const uint8_t*>(z.data());
            payload.assign(zb, zb + z.size());
        } else {
            rs = 0;
            for (std::size_t at = 0; at + 8 <= raw.size();) {
                uint64_t len = 0;
                std::memcpy(&len, raw.data() + at, 8);
                at += 8;
                len = std::min<uint64_t>(len, raw.size() - at);
                const std::vector<std::byte> z =
                    len ? tlod::zstd_compress(raw.subspan(at, len), 1) : std::vector<std::byte>{};
                const uint64_t zs = z.size();
                const auto* lb = reinterpret_cast<const uint8_t*>(&len);
                const auto* zl = reinterpret_cast<const uint8_t*>(&zs);
                const auto* zb = reinterpret_cast<const uint8_t*>(z.data());
                payload.insert(payload.end(), lb, lb + 8);
                payload.insert(payload.end(), zl, zl + 8);
                payload.insert(payload.end(), zb, zb + z.size());
                rs += 8 + len;
                at += len;
            }
        }
        bytes.resize(48);
        const uint64_t zs = payload.size();
        std::memcpy(bytes.data() + 32, &rs, 8);
        std::memcpy(bytes.data() + 40, &zs, 8);
        bytes.insert(bytes.end(), payload.begin(), payload.end());
    }
    // A field for headers that do not include one: small dims only (as the header says).
    Volume field;
    const Volume* supplied = nullptr;
    if (bytes.size() >= 48) {
        uint32_t d[3];
        std::memcpy(d, bytes.data() + 8, 12);
        const uint8_t t = bytes[20];
        const bool small = d[0] >= 1 && d[1] >= 1 && d[2] >= 1 && d[0] <= 4096 && d[1] <= 4096 && d[2] <= 4096 &&
                           uint64_t(d[0]) * d[1] * d[2] <= 4096;
        if (small && t >= 1 && t <= 8) {
            field = Volume::allocate({d[0], d[1], d[2]}, ValueType(t));
            for (std::size_t i = 0; i < field.data.size(); ++i) field.data[i] = std::byte(uint8_t(i * 37));
            supplied = &field;
        }
    }
    auto m = decode_mt(bytes, supplied);
    if (!m) return 0;
    for (double e : {-1.0, 0.0, 5.0}) {
        LodQuery q;
        q.error_in = e;
        try {
            (void)m->extract(q);
        } catch (const Error&) {
        }
    }
    try {
        (void)check_mt_bounds(*m);
    } catch (const Error&) {
    }
    return 0;
}
