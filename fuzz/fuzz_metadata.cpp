// libFuzzer target: the METADATA parser (spec §5). Whatever it accepts must
// serialize and parse back to the same metadata (the writer never writes what
// the reader refuses, and nothing is lost on the way).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "tetlod/format/metadata.hpp"

using namespace tetlod;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    auto m = tlod::parse_metadata(std::span<const std::byte>(reinterpret_cast<const std::byte*>(data), size));
    if (!m) return 0;
    const auto again = tlod::serialize_metadata(*m);
    auto back = tlod::parse_metadata(again);
    if (!back || !(back->dims == m->dims) || back->format_keys != m->format_keys || back->user_keys != m->user_keys)
        std::abort();
    return 0;
}
