#pragma once
// Exact per-diamond errors of the HT computed slab by slab, for volumes that do
// not fit in memory: the same floats as HtModel::build, from planes fed in order.
//
// A diamond of half-size h centred at c lies in planes c.z - h .. c.z + h.
//  - Small diamonds (h <= kReach) are evaluated whole once their centre's slab
//    arrives: the slab's window holds kReach more planes on each side.
//  - Larger ones are scanned row by row as their planes pass, keeping one
//    running maximum per diamond; a row costs the same arithmetic as in the
//    whole-field scan, so the maxima combine exactly. Their vertices are
//    multiples of h >= 2^kCoarseShift: the caller provides the field at those
//    points (the coarse lattice, one pass over the volume), since a row needs
//    the values at its tet's corners before the planes holding them arrive.
// Memory: the coarse lattice and the running maxima, about 1/2^15 of the grid
// in points, plus the caller's window.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "tetlod/core/value_type.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/models/ht/ht_model.hpp"

namespace tetlod {

/// Where an HtErrorSweep puts the errors it finishes.
class HtErrorPlaneSink {
public:
    virtual ~HtErrorPlaneSink() = default;
    /// The errors of cycle t (diamonds of half-size 2^t) centred in plane z (a
    /// multiple of 2^t), on that plane's lattice of spacing 2^t: centre (x, y)
    /// goes to entry (y >> t) * ((box_max.x >> t) + 1) + (x >> t). Entries that
    /// are not centres of cycle t are left alone. Called from several threads
    /// at once, never twice for one (t, z).
    virtual float* error_plane(int t, int64_t z) = 0;
};

class HtErrorSweep {
public:
    /// Planes beyond a slab, on each side, that its window must hold.
    static constexpr int kReach = 16;
    /// The coarse lattice holds the field at points whose coordinates are
    /// multiples of 2^kCoarseShift.
    static constexpr int kCoarseShift = 5;
    /// Dims of the coarse lattice of `domain` (x fastest).
    static Dims coarse_dims(const HtDomain& domain);

    /// `range`: the field's minimum and maximum (floats: the rounding slack).
    /// `coarse`: the field on the coarse lattice, coarse_dims(domain) values of `type`.
    HtErrorSweep(const HtDomain& domain, ValueType type, std::array<double, 2> range,
                 std::vector<std::byte> coarse);
    ~HtErrorSweep();
    HtErrorSweep(const HtErrorSweep&) = delete;
    HtErrorSweep& operator=(const HtErrorSweep&) = delete;

    /// Handles the slab of planes za..zb of B. Slabs come in order, each
    /// starting after the last (the first at 0, the last ending at box_max.z).
    /// `window` holds whole planes (x fastest) of the field on B from plane
    /// window_z0 on, at least planes max(0, za - kReach) .. min(box_max.z, zb + kReach).
    /// Every error whose diamond lies in planes <= zb is then in the sink.
    void process(const std::byte* window, int64_t window_z0, int64_t za, int64_t zb,
                 HtErrorPlaneSink& sink);

    /// Bytes held between slabs (coarse lattice, running maxima, templates).
    std::size_t memory_bytes() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace tetlod
