#pragma once
// Opening an HDF5 dataset for reading, shared by the whole-volume reader and
// the plane reader so both see the same header and the same checks: the path
// (no external links), the type, the rank and axis order, dims_xyz, the
// dataset's claims against the file's bytes (hdf5_read_guard), and the
// geometry, names and metadata from its attributes. Then the planes z0..z0+n-1
// by one hyperslab read. Private to tetlod_hdf5_io.
#include <hdf5.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hdf5_util.hpp"
#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::hdf5_detail {

/// Largest chunk cache a plane reader sets (a layer of chunks across a plane).
inline constexpr uint64_t kMaxPlaneCacheBytes = uint64_t{1} << 30;

struct Hdf5Source {
    Hid file, dataset;
    std::string what;     // 'file:dataset', for messages
    Volume header;        // dims, type, geometry, names, metadata; no samples
    int rank = 3;
    bool xyz = false;     // dataset axes are [x][y][z] (else C order [z][y][x])
    hsize_t shape[3] = {1, 1, 1};
    uint64_t cache_bytes = 0;  // chunk cache set for plane reads (0: the library's default)
};

/// Opens `dataset` of `file` (empty: the file's only dataset) and reads its
/// header; throws tetlod::Error naming the file and dataset. `file_size` is the
/// file's size (the claims are checked against it). `for_planes`: the chunk
/// cache is set to hold two layers of chunks across a plane (at most
/// kMaxPlaneCacheBytes), so reading plane after plane decodes each chunk once.
/// Safe on untrusted files only in a child process (the library may crash).
/// `fapl`: the file access property list (the MPI-IO driver for collective
/// reads, hdf5_mpi.cpp); every rank of its communicator must then call this.
Hdf5Source open_hdf5_source(const std::string& file, const std::string& dataset, const VolumeReadOptions& options,
                            uint64_t file_size, bool for_planes, hid_t fapl = H5P_DEFAULT);

/// Reads planes z0 .. z0 + count - 1 (in range: the caller checks) into dst,
/// x fastest in host order, converted by the library as the whole read is.
/// `scratch` holds the slab of an [x][y][z] dataset before it is transposed.
/// `dxpl`: the transfer property list (collective MPI-IO reads); count 0 then
/// selects nothing, so a rank with no planes left still joins the collective.
void read_hdf5_planes(const Hdf5Source& source, int64_t z0, int64_t count, std::byte* dst,
                      std::vector<std::byte>& scratch, hid_t dxpl = H5P_DEFAULT);

}  // namespace tetlod::hdf5_detail
