// Slabs of planes over ranks and the plane requests between them. See slab_planes.hpp.
#include "slab_planes.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>

#include "tetlod/core/error.hpp"

namespace tetlod::mpi {

namespace {

constexpr int kRequestTag = 7101, kPlanesTag = 7102;
// MPI counts are int: planes travel in pieces well below 2 GiB.
constexpr std::size_t kPieceBytes = std::size_t{1} << 30;

enum RequestKind : int64_t { kStop = 0, kPlanes = 1 };

// Receives rank 0's next request without spinning: Open MPI's blocking
// receive polls at full speed, and a serving rank waits through the whole
// encode; on a node it shares with rank 0 that poll takes the core the
// encoder's threads need (measured: 2 ranks on 2 cores were 35% slower than
// 1). A request waits at most the sleep (<= 2 ms) before it is answered.
void wait_idle(MPI_Comm comm, int64_t (&request)[3]) {
    MPI_Request pending;
    MPI_Irecv(request, 3, MPI_INT64_T, 0, kRequestTag, comm, &pending);
    auto pause = std::chrono::microseconds(50);
    for (;;) {
        int done = 0;
        MPI_Test(&pending, &done, MPI_STATUS_IGNORE);
        if (done) return;
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, std::chrono::microseconds(2000));
    }
}

}  // namespace

int SlabPartition::owner(int64_t z) const {
    // begin(r) = floor(planes * r / ranks): start from the estimate and step.
    int r = int(std::min<int64_t>(ranks - 1, z * ranks / std::max<int64_t>(planes, 1)));
    while (r > 0 && begin(r) > z) --r;
    while (r < ranks - 1 && end(r) <= z) ++r;
    return r;
}

LocalSlab read_local_slab(Hdf5MpiDataset& dataset, const SlabPartition& partition, int rank,
                          SlabTraffic& traffic, std::size_t batch_bytes) {
    const Volume& h = dataset.header();
    LocalSlab slab;
    slab.z0 = partition.begin(rank);
    slab.planes = partition.end(rank) - slab.z0;
    slab.plane_bytes = std::size_t(h.dims.x) * std::size_t(h.dims.y) * value_size(h.type);
    slab.data.resize(std::size_t(slab.planes) * slab.plane_bytes);
    // Every rank makes the same number of collective calls: as many as the
    // largest slab needs; a rank past its own planes joins with none.
    const int64_t batch = std::max<int64_t>(1, int64_t(batch_bytes / std::max<std::size_t>(slab.plane_bytes, 1)));
    const int64_t rounds = (partition.largest() + batch - 1) / batch;
    const auto start = std::chrono::steady_clock::now();
    for (int64_t i = 0; i < rounds; ++i) {
        const int64_t from = std::min(slab.planes, i * batch);
        const int64_t n = std::min(batch, slab.planes - from);
        dataset.read_planes(slab.z0 + from, n, slab.data.data() + std::size_t(from) * slab.plane_bytes);
    }
    traffic.read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    traffic.bytes_read = slab.data.size();
    return slab;
}

DistributedPlanes::DistributedPlanes(MPI_Comm comm, Volume header, const LocalSlab& own, SlabPartition partition,
                                     SlabTraffic& traffic)
    : comm_(comm), header_(std::move(header)), own_(own), partition_(partition), traffic_(traffic) {}

DistributedPlanes::~DistributedPlanes() { finish(); }

void DistributedPlanes::read(int64_t z0, int64_t count, std::byte* dst) {
    if (z0 < 0 || count < 0 || count > partition_.planes || z0 > partition_.planes - count)
        throw Error(ErrorCode::InvalidArgument, "planes " + std::to_string(z0) + ".." +
                                                    std::to_string(z0 + count - 1) + " outside the volume");
    const std::size_t plane = own_.plane_bytes;
    int64_t z = z0;
    while (z < z0 + count) {
        const int r = partition_.owner(z);
        const int64_t n = std::min(z0 + count, partition_.end(r)) - z;
        std::byte* out = dst + std::size_t(z - z0) * plane;
        if (r == 0) {
            std::memcpy(out, own_.data.data() + std::size_t(z - own_.z0) * plane, std::size_t(n) * plane);
        } else {
            const int64_t request[3] = {kPlanes, z, n};
            MPI_Send(request, 3, MPI_INT64_T, r, kRequestTag, comm_);
            ++traffic_.messages;
            const std::size_t bytes = std::size_t(n) * plane;
            for (std::size_t at = 0; at < bytes; at += kPieceBytes) {
                const int piece = int(std::min(kPieceBytes, bytes - at));
                MPI_Recv(out + at, piece, MPI_BYTE, r, kPlanesTag, comm_, MPI_STATUS_IGNORE);
                ++traffic_.messages;
            }
            traffic_.bytes_received += bytes;
        }
        z += n;
    }
}

void DistributedPlanes::finish() {
    if (finished_) return;
    finished_ = true;
    const int64_t stop[3] = {kStop, 0, 0};
    for (int r = 1; r < partition_.ranks; ++r) MPI_Send(stop, 3, MPI_INT64_T, r, kRequestTag, comm_);
}

void serve_planes(MPI_Comm comm, const LocalSlab& slab, SlabTraffic& traffic) {
    for (;;) {
        int64_t request[3] = {kStop, 0, 0};
        wait_idle(comm, request);
        ++traffic.messages;
        if (request[0] == kStop) return;
        // Rank 0 asks only for planes this rank owns (DistributedPlanes::read);
        // anything else is a bug, and rank 0 waits for the answer: end the job.
        const int64_t z = request[1], n = request[2];
        if (z < slab.z0 || n < 0 || n > slab.planes || z - slab.z0 > slab.planes - n) {
            std::fprintf(stderr, "tetlod-mpi: internal error: planes %lld+%lld asked of a rank holding %lld+%lld\n",
                         (long long)z, (long long)n, (long long)slab.z0, (long long)slab.planes);
            MPI_Abort(comm, 1);
        }
        const std::byte* from = slab.data.data() + std::size_t(z - slab.z0) * slab.plane_bytes;
        const std::size_t bytes = std::size_t(n) * slab.plane_bytes;
        for (std::size_t at = 0; at < bytes; at += kPieceBytes) {
            const int piece = int(std::min(kPieceBytes, bytes - at));
            MPI_Send(from + at, piece, MPI_BYTE, 0, kPlanesTag, comm);
            ++traffic.messages;
        }
        traffic.bytes_sent += bytes;
    }
}

}  // namespace tetlod::mpi
