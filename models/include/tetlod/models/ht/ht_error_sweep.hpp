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

    // ---- Distributed use: several sweeps, each over its own range of planes ----
    // A partial sweep takes slabs covering only its planes za..zb (in order,
    // the first starting at za, windows as for process()): the small diamonds
    // centred there are final and go to the sink; the large ones only collect
    // the maxima of the rows it holds. Every row scanned by exactly one sweep,
    // the maxima of the partial maxima (merge_partial_maxima, any grouping)
    // are the whole-field maxima, and finish_range() then hands over the same
    // floats as a whole sweep.

    /// Partial mode: process() no longer hands over large diamonds.
    void set_partial(bool partial);
    /// The running maxima of the large diamonds (bytes, the same size on every
    /// sweep of the same domain, type and range).
    std::vector<std::byte> partial_maxima() const;
    /// Takes the maximum with another sweep's partial_maxima() (a diamond
    /// crossing the data box stays so).
    void merge_partial_maxima(const std::byte* other, std::size_t bytes);
    /// Bytes of one running maximum in partial_maxima() (every one the same type).
    std::size_t partial_maximum_bytes() const;
    /// The same merge on buffers: `inout` becomes the maximum of `in` and
    /// `inout`, over `bytes` (a whole number of maxima, any aligned part of two
    /// partial_maxima(): what a reduction over processes needs). Never throws.
    void merge_maxima(const std::byte* in, std::byte* inout, std::size_t bytes) const;
    /// Hands over the large diamonds centred in planes za..zb (after the merge).
    void finish_range(int64_t za, int64_t zb, HtErrorPlaneSink& sink);

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace tetlod
