#pragma once
// Hooks for an HT conversion spread over processes (tetlod-mpi,
// docs/distributed.md §3.6): each process runs the two expensive parts of
// write_ht_container_streaming's passes over its own range of planes of the
// data box B, and the results combine into exactly what one process computes.
//
//  1. ht_scan_planes over za..zb: the value range, finiteness and the coarse
//     lattice points of those planes; ht_merge_scan folds the parts in plane
//     order (the same floats as the serial scan).
//  2. HtRangeErrors over za..zb: the errors of the diamonds centred there.
//     Diamonds small enough to lie in za - kReach .. zb + kReach are final at
//     once; larger ones are partial maxima over the rows of za..zb, merged
//     over all processes (a maximum of partial maxima is exact in any
//     grouping), then finish() writes their errors.
//  3. The process that encodes passes an HtErrorSource to the encoder
//     (HtStreamEncodeOptions::errors) that serves those errors, for instance
//     packed (ht_pack_errors) and sent by their owners.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/core/volume_planes.hpp"
#include "tetlod/models/ht/ht_error_sweep.hpp"

namespace tetlod {

/// Source planes (clamped to the volume) that planes za..zb of B need for
/// their errors: the planes themselves and HtErrorSweep::kReach on each side.
std::array<int64_t, 2> ht_source_planes_for(const HtDomain& domain, const Dims& source, int64_t za, int64_t zb);

struct HtScanPart {
    bool any = false;                    // some source sample lies in the planes
    std::array<double, 2> range{0, 0};   // their extremes (when any)
    std::vector<std::byte> coarse;       // the coarse lattice; zero outside the planes
};
/// Pass 1 over planes za..zb of B (za > zb: none). `source` serves the source
/// planes ht_source_planes_for(za, zb) (planes outside are not read). Throws
/// CorruptData at the first non-finite sample, as the serial scan does.
HtScanPart ht_scan_planes(VolumePlanes& source, bool pad, int64_t za, int64_t zb);
/// Folds `next` (planes after those of `into`) into `into`: the serial scan's
/// result when every part is folded in plane order.
void ht_merge_scan(HtScanPart& into, const HtScanPart& next);

/// The errors of the diamonds centred in planes za..zb of B (every cycle t < k).
class HtRangeErrors final : public HtErrorPlaneSink {
public:
    HtRangeErrors(VolumePlanes& source, bool pad, std::array<double, 2> range, std::vector<std::byte> coarse,
                  int64_t za, int64_t zb, int64_t slab_planes = 64);
    ~HtRangeErrors() override;
    /// Sweeps the planes (reads ht_source_planes_for(za, zb) from the source).
    void compute();
    /// The large diamonds' running maxima: merge those of every process, then finish().
    std::vector<std::byte> partial_maxima() const { return sweep_.partial_maxima(); }
    void merge_partial_maxima(const std::byte* other, std::size_t bytes) { sweep_.merge_partial_maxima(other, bytes); }
    void finish();

    const HtDomain& domain() const { return d_; }
    int64_t za() const { return za_; }
    int64_t zb() const { return zb_; }
    /// Packs the errors centred in planes z1..z2 (inside za..zb): see ht_pack_errors.
    void pack(int64_t z1, int64_t z2, float* out) const;
    /// Bytes held (the error planes).
    std::size_t bytes() const;

    float* error_plane(int t, int64_t z) override;

private:
    VolumePlanes& source_;
    HtDomain d_;
    int64_t za_, zb_, slab_;
    HtErrorSweep sweep_;
    std::vector<std::vector<float>> planes_;  // per cycle t < k: planes first_[t], + 2^t, ... <= zb
    std::vector<int64_t> first_;
};

/// Packed errors of planes z1..z2: for t = 0 .. k-1, for the planes z of
/// z1..z2 that are multiples of 2^t (ascending), the lattice plane of cycle t
/// ((box_max.x >> t) + 1) * ((box_max.y >> t) + 1) floats, as error_plane().
std::size_t ht_packed_error_floats(const HtDomain& domain, int64_t z1, int64_t z2);
void ht_unpack_errors(const HtDomain& domain, int64_t z1, int64_t z2, const float* packed, HtErrorPlaneSink& sink);

}  // namespace tetlod
