#pragma once
// A volume written into an HDF5 dataset by every rank of an MPI communicator
// through parallel HDF5 (the MPI-IO driver): each rank writes its own planes by
// hyperslab, in collective writes. Built only with TETLOD_WITH_MPI, into
// tetlod_hdf5_mpi_io (the parallel libhdf5; never beside the serial one).
//
// The dataset is the one write_hdf5 (hdf5.hpp) creates, through the same code
// (hdf5_dataset_write.cpp): shape (Z, Y, X), the volume's type, no times
// recorded, the same attributes. The same guarantees too: an existing HDF5
// file keeps its other datasets, groups and attributes, because the ranks
// write into a temporary copy beside it (Hdf5MpiStaging, prepared by one rank)
// that is renamed over the file only at the end.
#include <mpi.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "tetlod/core/volume.hpp"

namespace tetlod {

class AtomicPath;

/// One rank (rank 0), local, before any collective call: the checks
/// write_hdf5 makes under the installed OutputPolicy (`file:dataset` not an
/// input of the run; an existing dataset only with force; a group or other
/// object at `dataset` never; an existing non-HDF5 file only with force), then
/// the temporary file beside `file`: a copy of an existing HDF5 file, else
/// empty. Destroyed without commit(), it removes the temporary file.
class Hdf5MpiStaging {
public:
    Hdf5MpiStaging(const std::string& file, const std::string& dataset);
    ~Hdf5MpiStaging();
    Hdf5MpiStaging(const Hdf5MpiStaging&) = delete;
    Hdf5MpiStaging& operator=(const Hdf5MpiStaging&) = delete;

    const std::string& temp_path() const;
    /// The temporary file is a copy of an existing HDF5 file (else a new file is created).
    bool update() const { return update_; }
    /// Renames the temporary file over `file` (after every rank closed it).
    void commit();

private:
    std::unique_ptr<AtomicPath> path_;
    bool update_ = false;
};

class Hdf5MpiDatasetWriter {
public:
    virtual ~Hdf5MpiDatasetWriter() = default;
    /// Collective: every rank calls it the same number of times, each with its
    /// own planes z0 .. z0 + count - 1 (count may be 0), x fastest, host order.
    /// Throws tetlod::Error naming the file and dataset.
    virtual void write_planes(int64_t z0, int64_t count, const std::byte* src) = 0;
    /// Collective: writes the attributes and closes the dataset and the file.
    /// Without it (an error on some rank), destruction closes them without
    /// attributes: the temporary file is then to be removed.
    virtual void finish() = 0;
};

/// Collective over `comm`: opens the staged temporary file `temp` (`update`:
/// Hdf5MpiStaging::update(), broadcast by the rank that staged it) with the
/// MPI-IO driver on every rank and creates `dataset` for `header` (dims, type,
/// geometry, names, metadata; no samples), replacing an existing dataset of
/// that name (the staging rank checked that it may). `file`: the target, for
/// messages. Throws tetlod::Error naming the file and dataset.
std::unique_ptr<Hdf5MpiDatasetWriter> create_hdf5_mpi(const std::string& temp, bool update, const std::string& file,
                                                      const std::string& dataset, const Volume& header,
                                                      MPI_Comm comm);

}  // namespace tetlod
