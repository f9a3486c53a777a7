// libFuzzer target: the MetaImage reader, header and data (LOCAL or detached).
#include <cstddef>
#include <cstdint>

#include "fuzz_read_planes.hpp"
#include "fuzz_volume_header.hpp"
#include "tetlod/converters/metaimage.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    tetlod_fuzz::read_header_and_data(data, size, "h.mha",
                                      [](const std::string& p) { return tetlod::read_metaimage(p); });
    // The same input plane by plane (streams, several data files, offsets).
    tetlod_fuzz::read_header_and_data(data, size, "h.mha", [](const std::string& p) {
        tetlod::fuzz::read_every_plane(tetlod::open_metaimage_planes(p, {}));
        return tetlod::Volume{};
    });
    return 0;
}
