#pragma once
// HDF5 volumes through the HDF5 C library: one dataset of a file, addressed as
// FILE.h5:/path/to/dataset. Only hdf5_volume.cpp and hdf5_read_guard.cpp include hdf5.h.
//
// Read: a dataset of rank 1..3, any integer (8/16/32-bit; 64-bit integers when
// every value fits int32 are refused for simplicity: ErrorCode::UnsupportedFeature)
// or float type, either byte order, contiguous or chunked with any filter the
// library decodes (deflate, shuffle, ...).
//  - axis order: C order [z][y][x] (x fastest) by default, the numpy/h5py
//    convention. VolumeReadOptions::axis_order "xyz", or else an "axis_order"
//    attribute "xyz" on the dataset, means the first index is x.
//  - spacing: attribute "spacing" (3 numbers, x y z order unless an attribute
//    "spacing_order" says "zyx"), else "element_size_um" (in dataset axis order,
//    the Fiji/ilastik convention). Origin: attribute "origin" (x y z).
//    "field_name" and "units" attributes set those fields.
//  - every other attribute (numbers or strings) is kept in Volume::metadata as
//    text.
// Hostile files: the path must be a regular file (a FIFO is refused before it is
// opened) and the superblock is checked by tetlod itself; libhdf5 then reads in
// a child process (VolumeReadOptions::isolation), so a crash or endless loop in
// the library becomes ErrorCode::CorruptData. External links, virtual datasets
// and external raw-data files outside the file's folder (or not regular files)
// are refused; a chunked dataset may not declare more than 1100x its stored
// chunk bytes (+1 MiB) before anything is allocated.
// Large datasets are read in bounded slabs. Errors (missing file or dataset,
// wrong type, truncated file) are tetlod::Error naming the file and dataset.
#include <string>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

/// `dataset` empty: the file's only dataset (several: InvalidArgument listing them).
Volume read_hdf5(const std::string& file, const std::string& dataset, const VolumeReadOptions& options = {});

struct Hdf5WriteOptions {
    Endian endian = Endian::Little;
    /// 0: contiguous, uncompressed (bytes identical to a raw file). 1..9: chunked
    /// (one z-slab chunks) and deflate-compressed at that level.
    int deflate_level = 0;
};

/// Writes `dataset` (parent groups created) of shape (Z, Y, X), the volume's
/// type, attributes spacing (x y z), spacing_order "xyz", origin, dims_xyz,
/// axis_order "zyx", field_name, units, and every metadata entry as a string
/// attribute. A new `file` is created; an existing HDF5 `file` keeps every other
/// dataset, group and attribute: only `dataset` is added, or replaced when the
/// installed OutputPolicy (core/output_policy.hpp) allows replacing (a group at
/// that path is never replaced). Atomic: the update goes to a temporary copy in
/// the same directory, renamed over `file` (a symlink's target) at the end.
void write_hdf5(const Volume& volume, const std::string& file, const std::string& dataset,
                const Hdf5WriteOptions& options = {});

/// What write_hdf5(volume, file, dataset) would refuse under the installed
/// OutputPolicy, checked before any work: an existing non-HDF5 `file` or an
/// existing `dataset` without force (InvalidArgument via the policy), a group or
/// other object at `dataset` (InvalidArgument). Nothing is written.
void check_hdf5_output(const std::string& file, const std::string& dataset);

/// The metadata keys write_hdf5 leaves out, in key order: no attribute name
/// ("", "."), or the name of an attribute written from the Volume's own fields.
std::vector<std::string> hdf5_unstorable_keys(const Volume& volume);

}  // namespace tetlod
