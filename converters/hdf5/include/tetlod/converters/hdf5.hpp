#pragma once
// HDF5 volumes through the HDF5 C library: one dataset of a file, addressed as
// FILE.h5:/path/to/dataset. Only tetlod_hdf5_io's sources include hdf5.h.
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
#include <memory>
#include <string>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

/// `dataset` empty: the file's only dataset (several: InvalidArgument listing them).
Volume read_hdf5(const std::string& file, const std::string& dataset, const VolumeReadOptions& options = {});

/// The same dataset read plane by plane, each read one hyperslab (out-of-core
/// conversion): the header and samples of read_hdf5, in memory bounded by the
/// planes asked for plus a chunk cache holding two layers of chunks across a
/// plane (at most 1 GiB). Same checks as read_hdf5; with isolation on, libhdf5
/// runs in a persistent child process that keeps the file open and answers each
/// read (open_planes_isolated in core/isolated_planes.hpp), each read with its
/// own time limit and the child's memory capped by what a read needs. Reads are
/// not thread-safe (one at a time).
std::unique_ptr<VolumePlanes> open_hdf5_planes(const std::string& file, const std::string& dataset,
                                               const VolumeReadOptions& options = {});

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
/// the same directory, renamed over `file` (a symlink's target) at the end. No
/// time is recorded in the objects created (file, groups, dataset), so the same
/// volume written to a new file gives the same bytes.
void write_hdf5(const Volume& volume, const std::string& file, const std::string& dataset,
                const Hdf5WriteOptions& options = {});

/// The same from planes read one batch after the other (streaming decode): the
/// dataset is created, then written a batch of planes at a time by hyperslab
/// (16 MiB, or one plane when larger), with the attributes and guarantees of
/// write_hdf5 on the whole volume (other datasets kept, atomic) and, contiguous
/// (deflate_level 0, the default), the same bytes; deflated chunks hold the same
/// data but the library may place them in another order. An error reading the
/// planes leaves nothing at the target.
void write_hdf5(VolumePlanes& planes, const std::string& file, const std::string& dataset,
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
