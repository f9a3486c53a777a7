#pragma once
// The volume spread over ranks as slabs of whole z planes, and served to the
// rank that encodes (rank 0) plane by plane as the serial streaming encoder
// asks for them. Rank r holds planes begin(r) .. end(r) - 1 (Z/N each, the
// rest spread one per rank), read once from the file by a collective
// hyperslab read; rank 0's VolumePlanes fetches planes from their owners by
// point-to-point messages while the other ranks serve requests until told to
// stop. The encoder therefore sees exactly the planes `tetlod convert` reads,
// which is why the container is the same, byte for byte, for any N.
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

/// Rank 0's error source for the encoder: its own errors, and those of the
/// other ranks' planes by request (packed, ht_pack_errors).
class DistributedErrors final : public HtErrorSource {
public:
    DistributedErrors(MPI_Comm comm, std::array<double, 2> range, const HtRangeErrors& own, SlabPartition partition,
                      SlabTraffic& traffic)
        : comm_(comm), range_(range), own_(own), partition_(partition), traffic_(traffic) {}
    std::array<double, 2> range() const override { return range_; }
    void fill(int64_t za, int64_t zb, HtErrorPlaneSink& sink) override;

private:
    MPI_Comm comm_;
    std::array<double, 2> range_;
    const HtRangeErrors& own_;
    SlabPartition partition_;
    SlabTraffic& traffic_;
    std::vector<float> buffer_;
};

/// Rank 0's view of the whole volume: planes come from its own slab or, by
/// request, from the rank owning them. finish() must be called (also after a
/// failure) so the serving ranks stop.
class DistributedPlanes final : public VolumePlanes {
public:
    DistributedPlanes(MPI_Comm comm, Volume header, const LocalSlab& own, SlabPartition partition,
                      SlabTraffic& traffic);
    ~DistributedPlanes() override;
    const Volume& header() const override { return header_; }
    void read(int64_t z0, int64_t count, std::byte* dst) override;
    /// Tells every other rank to stop serving (once).
    void finish();

private:
    MPI_Comm comm_;
    Volume header_;
    const LocalSlab& own_;
    SlabPartition partition_;
    SlabTraffic& traffic_;
    bool finished_ = false;
};

/// Ranks other than 0: answer rank 0's requests for planes from `slab` and
/// for errors from `errors` until it says stop.
void serve_planes(MPI_Comm comm, const LocalSlab& slab, const HtRangeErrors& errors, SlabTraffic& traffic);

}  // namespace tetlod::mpi
