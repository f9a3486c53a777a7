// libFuzzer target: the HT section decoders (spec §6-§8). The input is the
// payloads of an HT container separated by "@SEC": METADATA (raw, §5), HT_HEADER
// (24 bytes, §6.1), then the chunk sections in file order. The harness frames them
// with a valid header and table (types, cycles and bricks from the HT_HEADER's
// geometry), so every mutation reaches the layout checks and the range decoders.
// A chunk payload may start with "MODE", a byte f and a u64 raw size (format 3.0
// chunk modes, spec §6.4): the section's table flags get mode f & 15, and ZSTD
// when f & 16 (its raw size then that u64), so the mode checks are reached too.
// A decoded HT of at most 2^15 grid points also has its bounds checked
// (check_ht_bounds, what verify --deep runs): it may report violations, never crash.
#include <cstddef>
#include <algorithm>
#include <cstdint>
#include <span>
#include <string_view>

#include "fuzz_split.hpp"
#include "tetlod/analysis/ht_bound_check.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"

using namespace tetlod;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const auto parts = tetlod_fuzz::split(std::string_view(reinterpret_cast<const char*>(data), size), "@SEC", 4096);
    if (parts.size() < 2) return 0;
    auto bytes = [](std::string_view s) {
        const auto* p = reinterpret_cast<const std::byte*>(s.data());
        return std::vector<std::byte>(p, p + s.size());
    };
    tlod::ContainerWriter w;
    w.set_features(tlod::kFeatureHt);
    w.add_stored(tlod::kSectionMetadata, tlod::kSectionCritical, 0, 0, bytes(parts[0]), parts[0].size());
    w.add_stored(tlod::kSectionHtHeader, tlod::kSectionCritical, 0, 0, bytes(parts[1]), parts[1].size());
    // Chunk order of §6.2 from the HT_HEADER's k, brick size and box (when readable).
    std::size_t next = 2;
    if (parts[1].size() >= 20) {
        const auto* h = reinterpret_cast<const std::byte*>(parts[1].data());
        const int k = std::min(int(std::to_integer<uint8_t>(h[0])), 12);
        const int g = std::min(int(std::to_integer<uint8_t>(h[2])), 16);
        int64_t box[3];
        for (int a = 0; a < 3; ++a) box[a] = int64_t(tlod::load_le(h + 8 + 4 * a, 4));
        for (int t = k; t >= 0 && next + 1 < parts.size(); --t) {
            const int64_t side = int64_t{1} << (t + 1 + g);
            // Capped by the parts there are (no overflow on a hostile box).
            const int64_t cap = int64_t(parts.size());
            int64_t nb = 1;
            for (int a = 0; a < 3; ++a) nb = std::min(cap, nb * std::min(cap, std::max<int64_t>(1, (box[a] + side - 1) / side)));
            for (int64_t b = 0; b < nb && next + 1 < parts.size(); ++b) {
                for (uint32_t type : {uint32_t(tlod::kSectionHtField), uint32_t(tlod::kSectionHtErrors)}) {
                    std::string_view p = parts[next++];
                    uint32_t flags = tlod::kSectionCritical;
                    uint64_t raw = 0;
                    if (p.size() >= 13 && p.substr(0, 4) == "MODE") {
                        const auto* q = reinterpret_cast<const std::byte*>(p.data());
                        const uint8_t f = std::to_integer<uint8_t>(q[4]);
                        flags |= uint32_t(f & 15) << tlod::kSectionModeShift;
                        if (f & 16) flags |= tlod::kSectionZstd;
                        raw = tlod::load_le(q + 5, 8);
                        p.remove_prefix(13);
                    }
                    if (!(flags & tlod::kSectionZstd)) raw = p.size();
                    w.add_stored(type, flags, uint32_t(t), uint32_t(b), bytes(p), raw);
                }
            }
        }
    }
    const std::vector<std::byte> file = w.finish();
    {
        auto r = tlod::ContainerReader::from_memory(file);
        if (!r) return 0;
        auto d = decode_ht(*r);
        if (d && d->field.dims.count() <= (int64_t(1) << 15)) {
            const HtDomain& dom = d->layout.domain;
            try {
                (void)check_ht_bounds(d->field, dom.k, {dom.box_max[0], dom.box_max[1], dom.box_max[2]},
                                      std::span<const float>(d->errors.data(), d->errors.size()), d->layout.max_error);
            } catch (const Error&) {
            }
        }
    }
    {  // a coarse box request and the lazy extraction read other subsets of chunks
        auto r = tlod::ContainerReader::from_memory(file);
        HtDecodeRequest q;
        q.finest_cycle = 1;
        q.box = std::array<int64_t, 6>{0, 0, 0, 2, 2, 2};
        (void)decode_ht(*r, q);
    }
    {
        auto r = tlod::ContainerReader::from_memory(file);
        LodQuery q;
        q.error_in = 1.0;
        try {
            (void)extract_ht_lazy(*r, q);
        } catch (const Error&) {
        }
    }
    {  // the volume plane by plane: a row of the finest bricks, its chunks decoded in parallel
        auto r = tlod::ContainerReader::from_memory(file);
        if (!r) return 0;
        auto planes = open_ht_planes(std::move(*r), std::size_t{1} << 20);
        if (!planes) return 0;
        const Dims d = (*planes)->header().dims;
        const std::size_t plane = std::size_t(d.x * d.y) * value_size((*planes)->header().type);
        if (plane > (std::size_t{1} << 24)) return 0;  // the harness's own buffer, not the decoder's
        std::vector<std::byte> buf(plane);
        try {
            (*planes)->read(d.z - 1, 1, buf.data());
        } catch (const Error&) {
        }
    }
    return 0;
}
