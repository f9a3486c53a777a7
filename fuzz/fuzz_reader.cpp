// libFuzzer target: the .tlod reader on arbitrary bytes (header, table: full
// or compact (format 3.2, its zstd frame decoded: fuzzing builds skip checksums),
// metadata, HT layout, full decode, MT sections and an MT extraction). Must never
// crash, hang or read out of bounds.
#include <cstddef>
#include <cstdint>
#include <span>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/format/container.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
    auto r = tetlod::tlod::ContainerReader::from_memory(bytes);
    if (!r) return 0;
    for (std::size_t i = 0; i < r->sections().size(); ++i) (void)r->read_section(i);
    auto r2 = tetlod::tlod::ContainerReader::from_memory(bytes);
    (void)tetlod::decode_ht(*r2);
    auto r3 = tetlod::tlod::ContainerReader::from_memory(bytes);
    if (auto m = tetlod::decode_mt_container(*r3); m.ok()) {
        tetlod::LodQuery q;
        q.error_in = 0.0;
        try {
            (void)m->extract(q);  // may throw CorruptData on an inconsistent MT, never crash
        } catch (const tetlod::Error&) {
        }
    }
    return 0;
}
