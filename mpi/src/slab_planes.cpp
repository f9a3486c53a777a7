// Slabs of planes over ranks. See slab_planes.hpp.
#include "slab_planes.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdio>
#include <cstring>
#include <string>

#include "tetlod/core/error.hpp"

namespace tetlod::mpi {

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

}  // namespace tetlod::mpi
