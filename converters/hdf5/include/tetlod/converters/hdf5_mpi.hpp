#pragma once
// An HDF5 dataset read by every rank of an MPI communicator through parallel
// HDF5 (the MPI-IO driver): each rank reads its own planes by hyperslab, in
// collective reads. Built only with TETLOD_WITH_MPI, into tetlod_hdf5_mpi_io,
// which links the parallel libhdf5 (never beside the serial one in a program).
//
// Same header and checks as open_hdf5_planes (hdf5.hpp; the same source file
// opens the dataset), except that libhdf5 runs in this process: the rank
// processes are not isolated from a crash in the library (the serial reader
// forks a child; forking under MPI is unsafe with several transports).
#include <mpi.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

/// Local checks before any collective call, so that a rank which cannot see
/// the file fails alone instead of leaving the others waiting in MPI-IO: a
/// regular file, its HDF5 superblock. Returns the file's size. Throws
/// tetlod::Error naming the file.
uint64_t check_hdf5_mpi_input(const std::string& file);

class Hdf5MpiDataset {
public:
    virtual ~Hdf5MpiDataset() = default;
    /// Dims, type, spacing, origin, names and metadata; `data` stays empty.
    virtual const Volume& header() const = 0;
    /// Collective: every rank of the communicator calls it the same number of
    /// times, each with its own planes z0 .. z0 + count - 1 (count may be 0).
    /// Throws tetlod::Error naming the file and dataset.
    virtual void read_planes(int64_t z0, int64_t count, std::byte* dst) = 0;
};

/// Collective over `comm`: opens `dataset` of `file` (empty: the only one) on
/// every rank. `file_size` from check_hdf5_mpi_input. Throws tetlod::Error
/// naming the file and dataset (missing dataset: NotFound; bad type or rank:
/// UnsupportedFeature; ...), the same error on every rank since each reads the
/// same metadata.
std::unique_ptr<Hdf5MpiDataset> open_hdf5_mpi(const std::string& file, const std::string& dataset,
                                              const VolumeReadOptions& options, uint64_t file_size,
                                              MPI_Comm comm);

}  // namespace tetlod
