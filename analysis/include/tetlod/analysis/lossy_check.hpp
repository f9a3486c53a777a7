#pragma once
// `verify --original`: whether a container's stored field is within its
// stated bound of the original volume (E for a lossy container, format 3.1;
// 0, i.e. bit-exact, for a lossless one), sample by sample, plane by plane.
#include <cstdint>
#include <string>

#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

struct OriginalCheck {
    double max_error = 0;      // the container's stated bound (0: lossless)
    uint64_t samples = 0;      // compared
    uint64_t beyond = 0;       // farther than max_error from the original (lossless: not bit-identical)
    double max_deviation = 0;  // largest |stored - original|, in double
    std::array<int64_t, 3> first_beyond{-1, -1, -1};
    bool ok() const { return beyond == 0; }
};

/// Compares the HT container's field with `original` (same dims and value
/// type, else InvalidArgument). Throws tetlod::Error for an unreadable container.
OriginalCheck check_against_original(const std::string& container, VolumePlanes& original);

}  // namespace tetlod
