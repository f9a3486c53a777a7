#pragma once
// The volume spread over ranks as slabs of whole z planes. Rank r holds planes
// begin(r) .. end(r) - 1 (Z/N each, the rest spread one per rank) and the
// halo its errors need, read once from the file by collective hyperslab
// reads. (Step 1 and 2's plane and error requests to rank 0 are gone: every
// rank encodes its own rows, rank_encode.hpp.)
#include <mpi.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "tetlod/codecs/ht/ht_distributed.hpp"
#include "tetlod/converters/hdf5_mpi.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod::mpi {

/// Planes 0 .. planes - 1 (of the data box B, as the encoder sees it) cut
/// into `ranks` contiguous slabs of nearly equal size.
struct SlabPartition {
    int64_t planes = 0;
    int ranks = 1;
    int64_t begin(int r) const { return planes * r / ranks; }
    int64_t end(int r) const { return begin(r + 1); }
    int owner(int64_t z) const;
    int64_t largest() const { return (planes + ranks - 1) / ranks; }
};

/// What one rank moved, for the report (-v) and docs/distributed.md.
struct SlabTraffic {
    uint64_t bytes_read = 0;       // from the file
    uint64_t bytes_sent = 0;       // lattice planes for other ranks' rows, partial maxima, section entries
    uint64_t bytes_received = 0;   // lattice planes for its rows, partial maxima, entries (rank 0)
    uint64_t messages = 0;         // point-to-point messages sent and received
    double read_seconds = 0;
    double scan_seconds = 0;   // first pass over its planes
    double error_seconds = 0;  // errors of its planes (before the merge)
    double encode_seconds = 0; // encoding its rows of bricks (step 3)
    uint64_t bytes_written = 0;  // to the container (MPI-IO)
    double cpu_seconds = 0;    // user CPU time of the process, at the end
};

/// One rank's slab: the source planes its planes of B need for their errors
/// (its own and HtErrorSweep::kReach more on each side, clamped to the
/// volume: neighbouring slabs overlap there), read by every rank together
/// (collective reads of at most `batch_bytes` per rank and call, so no MPI-IO
/// request nears 2 GiB).
struct LocalSlab {
    int64_t z0 = 0, planes = 0;
    std::size_t plane_bytes = 0;
    std::vector<std::byte> data;
};
/// Source planes [first, last] rank r reads (ht_source_planes_for).
std::array<int64_t, 2> slab_source_planes(const HtDomain& domain, const Dims& dims, const SlabPartition& partition,
                                          int r);
LocalSlab read_local_slab(Hdf5MpiDataset& dataset, const HtDomain& domain, const SlabPartition& partition, int rank,
                          SlabTraffic& traffic, std::size_t batch_bytes = std::size_t{256} << 20);

/// The slab as planes of the whole volume (only its own planes can be read).
class LocalSlabPlanes final : public VolumePlanes {
public:
    LocalSlabPlanes(Volume header, const LocalSlab& slab) : header_(std::move(header)), slab_(slab) {}
    const Volume& header() const override { return header_; }
    void read(int64_t z0, int64_t count, std::byte* dst) override;

private:
    Volume header_;
    const LocalSlab& slab_;
};

}  // namespace tetlod::mpi
