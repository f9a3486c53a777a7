#pragma once
// Shared by the readers' targets: the planes of an input read forward, then the
// last plane again and the first (a compressed stream restarts, a persistent
// child answers out of order), one plane in memory. The buffer is sized from
// the header the reader validated, as the encoder sizes its own.
#include <cstddef>
#include <memory>
#include <vector>

#include "tetlod/core/volume_planes.hpp"

namespace tetlod::fuzz {

inline void read_every_plane(std::unique_ptr<VolumePlanes> planes) {
    if (!planes) return;
    const Volume& h = planes->header();
    std::vector<std::byte> plane(static_cast<std::size_t>(h.dims.x * h.dims.y) *
                                 value_size(h.type));
    for (int64_t z = 0; z < h.dims.z; ++z) planes->read(z, 1, plane.data());
    planes->read(h.dims.z - 1, 1, plane.data());
    planes->read(0, 1, plane.data());
}

}  // namespace tetlod::fuzz
