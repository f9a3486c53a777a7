// Stored field against the original volume (see lossy_check.hpp).
#include "tetlod/analysis/lossy_check.hpp"

#include <cmath>
#include <cstring>
#include <vector>

#include "tetlod/codecs/ht/ht_codec.hpp"

namespace tetlod {

OriginalCheck check_against_original(const std::string& container, VolumePlanes& original) {
    auto reader = tlod::ContainerReader::open(container);
    if (!reader) raise(reader.failure());
    auto layout = read_ht_layout(*reader);
    if (!layout) raise(layout.failure());
    auto stored = open_ht_planes(container);
    if (!stored) raise(stored.failure());
    const Volume& sh = (*stored)->header();
    const Volume& oh = original.header();
    if (!(sh.dims == oh.dims) || sh.type != oh.type)
        throw Error(ErrorCode::InvalidArgument, "the original is " + std::to_string(oh.dims.x) + "x" +
                                                    std::to_string(oh.dims.y) + "x" + std::to_string(oh.dims.z) +
                                                    " " + value_type_name(oh.type) + ", the container holds " +
                                                    std::to_string(sh.dims.x) + "x" + std::to_string(sh.dims.y) +
                                                    "x" + std::to_string(sh.dims.z) + " " +
                                                    value_type_name(sh.type));
    OriginalCheck c;
    c.max_error = layout->max_error;
    const std::size_t plane = std::size_t(sh.dims.x * sh.dims.y), vs = value_size(sh.type);
    std::vector<std::byte> a(plane * vs), b(plane * vs);
    for (int64_t z = 0; z < sh.dims.z; ++z) {
        (*stored)->read(z, 1, a.data());
        original.read(z, 1, b.data());
        dispatch_value_type(sh.type, [&](auto tag) {
            using T = decltype(tag);
            const T* s = reinterpret_cast<const T*>(a.data());
            const T* o = reinterpret_cast<const T*>(b.data());
            for (std::size_t i = 0; i < plane; ++i) {
                // Lossless: bit-identical (NaN payloads, -0); lossy: within E.
                const double d = std::fabs(double(s[i]) - double(o[i]));
                const bool bad = c.max_error > 0 ? !(d <= c.max_error) : std::memcmp(&s[i], &o[i], sizeof(T)) != 0;
                if (d > c.max_deviation) c.max_deviation = d;
                if (bad && c.beyond++ == 0)
                    c.first_beyond = {int64_t(i) % sh.dims.x, int64_t(i) / sh.dims.x, z};
            }
        });
        c.samples += plane;
    }
    return c;
}

}  // namespace tetlod
