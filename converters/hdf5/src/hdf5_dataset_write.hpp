#pragma once
// Writing a volume's dataset into an open HDF5 file, shared by the serial
// writer (hdf5_volume.cpp, write_hdf5) and the parallel one (hdf5_mpi_write.cpp,
// tetlod-mpi decode) so that both create the same dataset: shape (Z, Y, X), the
// volume's file type, no times recorded, the same attributes in the same order.
// Only how the file is opened (the driver) and how the samples are written
// differ. Private to tetlod_hdf5_io and tetlod_hdf5_mpi_io.
#include <hdf5.h>

#include <memory>
#include <string>

#include "hdf5_util.hpp"
#include "tetlod/converters/hdf5.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/output_policy.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::hdf5_detail {

/// True when `path` is a file the library recognises as HDF5.
bool is_hdf5_file(const std::string& path);

/// The temporary file beside `file` (symlinks followed) that the writer fills
/// and renames over it at the end: atomicity, since the library writes the
/// file by name. An existing HDF5 file is copied into it first (`update`), so
/// its other datasets, groups and attributes survive; an existing file that is
/// not HDF5 would be replaced whole, which `policy` must allow. `file:dataset`
/// may not be an input of the run. Throws tetlod::Error.
struct StagedOutput {
    std::unique_ptr<AtomicPath> path;  // removes the temporary file unless committed
    bool update = false;
};
StagedOutput stage_output(const std::string& file, const std::string& dataset, const OutputPolicy* policy);

/// Opens the temporary file `temp` read-write (`update`: a copy of an existing
/// HDF5 file) or creates it (no times recorded in its root group). `fapl`:
/// H5P_DEFAULT, or the MPI-IO driver (collective: every rank calls it).
/// `file`: the target, for messages.
Hid open_output_file(const std::string& temp, bool update, hid_t fapl, const std::string& file,
                     const std::string& what);

/// Makes room for `dataset` in `f` (when `update`: an existing dataset there is
/// unlinked if `policy` allows it, or always when `policy` is null, the caller
/// having asked it; a group is never replaced), creates the missing parent
/// groups and the dataset itself (contiguous, or deflated chunks of one plane
/// per `options`), untimed. Returns it open.
Hid create_volume_dataset(hid_t f, const std::string& file, const std::string& dataset, const Volume& header,
                          const Hdf5WriteOptions& options, bool update, const OutputPolicy* policy,
                          const std::string& what);

/// The attributes write_hdf5 gives a dataset: spacing, spacing_order, origin,
/// dims_xyz, axis_order, field_name, units, then every storable metadata entry.
void write_volume_attributes(hid_t d, const Volume& header, const std::string& what);

}  // namespace tetlod::hdf5_detail
