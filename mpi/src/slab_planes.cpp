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

enum RequestKind : int64_t { kStop = 0, kPlanes = 1, kErrors = 2 };

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

std::array<int64_t, 2> slab_source_planes(const HtDomain& domain, const Dims& dims, const SlabPartition& partition,
                                          int r) {
    return ht_source_planes_for(domain, dims, partition.begin(r), partition.end(r) - 1);
}

LocalSlab read_local_slab(Hdf5MpiDataset& dataset, const HtDomain& domain, const SlabPartition& partition, int rank,
                          SlabTraffic& traffic, std::size_t batch_bytes) {
    const Volume& h = dataset.header();
    LocalSlab slab;
    const auto mine = slab_source_planes(domain, h.dims, partition, rank);
    slab.z0 = mine[0];
    slab.planes = mine[1] - mine[0] + 1;
    slab.plane_bytes = std::size_t(h.dims.x) * std::size_t(h.dims.y) * value_size(h.type);
    slab.data.resize(std::size_t(slab.planes) * slab.plane_bytes);
    // Every rank makes the same number of collective calls: as many as the
    // largest slab needs; a rank past its own planes joins with none.
    int64_t largest = 0;
    for (int r = 0; r < partition.ranks; ++r) {
        const auto p = slab_source_planes(domain, h.dims, partition, r);
        largest = std::max(largest, p[1] - p[0] + 1);
    }
    const int64_t batch = std::max<int64_t>(1, int64_t(batch_bytes / std::max<std::size_t>(slab.plane_bytes, 1)));
    const int64_t rounds = (largest + batch - 1) / batch;
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

void LocalSlabPlanes::read(int64_t z0, int64_t count, std::byte* dst) {
    if (count < 0 || z0 < slab_.z0 || z0 - slab_.z0 > slab_.planes - count)
        throw Error(ErrorCode::InvalidArgument, "planes " + std::to_string(z0) + ".." + std::to_string(z0 + count - 1) +
                                                    " outside this rank's slab");
    std::memcpy(dst, slab_.data.data() + std::size_t(z0 - slab_.z0) * slab_.plane_bytes,
                std::size_t(count) * slab_.plane_bytes);
}

void DistributedErrors::fill(int64_t za, int64_t zb, HtErrorPlaneSink& sink) {
    const HtDomain& d = own_.domain();
    int64_t z = za;
    while (z <= zb) {
        const int r = partition_.owner(z);
        const int64_t z2 = std::min(zb, partition_.end(r) - 1);
        buffer_.resize(ht_packed_error_floats(d, z, z2));
        if (r == 0) {
            own_.pack(z, z2, buffer_.data());
        } else {
            const int64_t request[3] = {kErrors, z, z2 - z + 1};
            MPI_Send(request, 3, MPI_INT64_T, r, kRequestTag, comm_);
            ++traffic_.messages;
            const std::size_t bytes = buffer_.size() * sizeof(float);
            auto* out = reinterpret_cast<std::byte*>(buffer_.data());
            for (std::size_t at = 0; at < bytes; at += kPieceBytes) {
                const int piece = int(std::min(kPieceBytes, bytes - at));
                MPI_Recv(out + at, piece, MPI_BYTE, r, kPlanesTag, comm_, MPI_STATUS_IGNORE);
                ++traffic_.messages;
            }
            traffic_.bytes_received += bytes;
        }
        ht_unpack_errors(d, z, z2, buffer_.data(), sink);
        z = z2 + 1;
    }
}

DistributedPlanes::DistributedPlanes(MPI_Comm comm, Volume header, const LocalSlab& own, SlabPartition partition,
                                     SlabTraffic& traffic)
    : comm_(comm), header_(std::move(header)), own_(own), partition_(partition), traffic_(traffic) {}

DistributedPlanes::~DistributedPlanes() { finish(); }

void DistributedPlanes::read(int64_t z0, int64_t count, std::byte* dst) {
    if (z0 < 0 || count < 0 || count > header_.dims.z || z0 > header_.dims.z - count)
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

void serve_planes(MPI_Comm comm, const LocalSlab& slab, const HtRangeErrors& errors, SlabTraffic& traffic) {
    std::vector<float> packed;
    for (;;) {
        int64_t request[3] = {kStop, 0, 0};
        wait_idle(comm, request);
        ++traffic.messages;
        if (request[0] == kStop) return;
        // Rank 0 asks only for planes this rank holds (DistributedPlanes::read,
        // DistributedErrors::fill); anything else is a bug, and rank 0 waits for
        // the answer: end the job.
        const int64_t z = request[1], n = request[2];
        const bool planes = request[0] == kPlanes;
        const int64_t lo = planes ? slab.z0 : errors.za(), held = planes ? slab.planes : errors.zb() - errors.za() + 1;
        if (z < lo || n < 0 || n > held || z - lo > held - n) {
            std::fprintf(stderr, "tetlod-mpi: internal error: %s %lld+%lld asked of a rank holding %lld+%lld\n",
                         planes ? "planes" : "errors of planes", (long long)z, (long long)n, (long long)lo,
                         (long long)held);
            MPI_Abort(comm, 1);
        }
        const std::byte* from = nullptr;
        std::size_t bytes = 0;
        if (planes) {
            from = slab.data.data() + std::size_t(z - slab.z0) * slab.plane_bytes;
            bytes = std::size_t(n) * slab.plane_bytes;
        } else {
            packed.resize(ht_packed_error_floats(errors.domain(), z, z + n - 1));
            errors.pack(z, z + n - 1, packed.data());
            from = reinterpret_cast<const std::byte*>(packed.data());
            bytes = packed.size() * sizeof(float);
        }
        for (std::size_t at = 0; at < bytes; at += kPieceBytes) {
            const int piece = int(std::min(kPieceBytes, bytes - at));
            MPI_Send(from + at, piece, MPI_BYTE, 0, kPlanesTag, comm);
            ++traffic.messages;
        }
        traffic.bytes_sent += bytes;
    }
}

}  // namespace tetlod::mpi
