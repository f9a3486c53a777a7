// libFuzzer target: the MetaImage reader, header and data (LOCAL or detached).
#include <cstddef>
#include <cstdint>

#include "fuzz_volume_header.hpp"
#include "tetlod/converters/metaimage.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    tetlod_fuzz::read_header_and_data(data, size, "h.mha",
                                      [](const std::string& p) { return tetlod::read_metaimage(p); });
    return 0;
}
