#pragma once
// A volume read plane by plane (z slices, x fastest), so a consumer holds only
// the planes it works on: the input of out-of-core conversion. A format that
// can address its samples (raw and uncompressed NRRD/MetaImage by offset)
// reads just the planes asked for.
#include <cstddef>
#include <cstdint>
#include <memory>

#include "tetlod/core/volume.hpp"

namespace tetlod {

class VolumePlanes {
public:
    virtual ~VolumePlanes() = default;
    /// Dims, type, spacing, origin, names and metadata; `data` stays empty.
    virtual const Volume& header() const = 0;
    /// Reads planes z0 .. z0 + count - 1 into dst (count * dims.x * dims.y
    /// values, host byte order). Planes may be read in any order, more than
    /// once. Throws tetlod::Error naming the file (IoError, Truncated).
    virtual void read(int64_t z0, int64_t count, std::byte* dst) = 0;
};

/// `inner`'s planes under another header (metadata added by the user, say);
/// the header's dims and type must be inner's (else InvalidArgument).
std::unique_ptr<VolumePlanes> with_header(std::unique_ptr<VolumePlanes> inner, Volume header);

/// Every plane read into one volume (with the header's geometry, names and metadata).
Volume read_all_planes(VolumePlanes& planes);

/// The planes of a volume already in memory (which must outlive the result).
std::unique_ptr<VolumePlanes> planes_of(const Volume& volume);
/// The same, owning the volume.
std::unique_ptr<VolumePlanes> planes_owning(Volume volume);

}  // namespace tetlod
