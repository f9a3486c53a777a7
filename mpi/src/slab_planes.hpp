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

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "tetlod/converters/hdf5_mpi.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod::mpi {

/// Planes 0 .. planes - 1 cut into `ranks` contiguous slabs of nearly equal size.
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
    uint64_t bytes_sent = 0;       // planes sent to rank 0
    uint64_t bytes_received = 0;   // planes received (rank 0)
    uint64_t messages = 0;         // point-to-point messages sent and received
    double read_seconds = 0;
};

/// One rank's slab: its planes, read by every rank together (collective reads
/// of at most `batch_bytes` per rank and call, so no MPI-IO request nears 2 GiB).
struct LocalSlab {
    int64_t z0 = 0, planes = 0;
    std::size_t plane_bytes = 0;
    std::vector<std::byte> data;
};
LocalSlab read_local_slab(Hdf5MpiDataset& dataset, const SlabPartition& partition, int rank,
                          SlabTraffic& traffic, std::size_t batch_bytes = std::size_t{256} << 20);

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

/// Ranks other than 0: answer rank 0's requests from `slab` until it says stop.
void serve_planes(MPI_Comm comm, const LocalSlab& slab, SlabTraffic& traffic);

}  // namespace tetlod::mpi
