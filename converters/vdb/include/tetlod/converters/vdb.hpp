#pragma once
// OpenVDB volumes (.vdb) through the OpenVDB library. This header names no
// OpenVDB type, so including it costs nothing; only vdb_volume.cpp includes
// openvdb.h.
//
// Read: one grid, chosen by VolumeReadOptions::grid or, when empty, the only
// scalar grid in the file (several: ErrorCode::InvalidArgument listing them;
// none or a wrong name: ErrorCode::NotFound listing the scalar grids).
//  - grid types Float, Double, Int32, Int64 (values must fit i32 or u32, as
//    tetlod volumes hold at most 32-bit integers; staged through a double copy)
//    and Bool (read as u8 0/1).
//  - extent: grid metadata "dims_xyz" (voxels 0..dims-1) when present and it
//    contains every active voxel; otherwise the active-voxel bounding box.
//    Inactive voxels take the grid's background value.
//  - transform: linear with a diagonal, positive scale (uniform or not) becomes
//    spacing, its translation (at the first dense voxel) the origin; a rotation,
//    shear, flip, or non-linear (frustum) transform is ErrorCode::UnsupportedFeature.
//  - grid metadata go to Volume::metadata as text (except OpenVDB's own file_*
//    statistics). "tetlod_value_type" or "original_dtype" restores an integer
//    type stored as float when every value converts exactly. "vdb:grid_type"
//    records the grid's value type (float, double, int32, int64, bool), so
//    write_vdb writes the same grid type again.
// Safe on untrusted input: errors from the library become tetlod::Error naming
// the file. The path must be a regular file; tetlod parses the header, grid
// descriptors and grid metadata itself first (every length within the file),
// then OpenVDB reads in a child process (VolumeReadOptions::isolation) so a
// crash or hang in the library becomes ErrorCode::CorruptData. The dense extent
// (dims_xyz or the active bounding box) may need at most 4096 bytes per file
// byte + 64 MiB (ErrorCode::TooLarge); dims_xyz that is not three positive
// integers is ErrorCode::CorruptData.
#include <memory>
#include <string>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

Volume read_vdb(const std::string& path, const VolumeReadOptions& options = {});

/// The same grid plane by plane (out-of-core conversion): the header and
/// samples of read_vdb, without a dense copy of the volume on either side. With
/// isolation on, OpenVDB loads the grid in a persistent child process (same
/// checks and limits as read_vdb) that fills each plane request from the sparse
/// grid; with isolation off, in this process. The grid itself stays in memory
/// (OpenVDB reads a grid whole), so this bounds the dense samples, not the grid.
/// Reads are not thread-safe (one at a time).
std::unique_ptr<VolumePlanes> open_vdb_planes(const std::string& path, const VolumeReadOptions& options = {});

/// Names and types ("float", "int32", ...) of every grid in the file.
std::vector<std::pair<std::string, std::string>> list_vdb_grids(const std::string& path);

/// Writes one grid named after Volume::field_name. Grid type: the one the volume
/// was read from (read_vdb sets metadata "vdb:grid_type": float, double, int32,
/// int64 or bool) when it holds every value exactly, so a FloatGrid comes back
/// a FloatGrid; otherwise f32 -> FloatGrid, f64 -> DoubleGrid, other integer
/// types -> Int32Grid (u32 -> Int64Grid). Metadata "tetlod_value_type" lets
/// reading restore the exact value type. Metadata keys a grid cannot hold
/// (empty, OpenVDB's own or the ones written from Volume fields) are left out:
/// callers report vdb_unstorable_keys(). Voxels equal (bit for
/// bit) to the background 0 stay inactive; "dims_xyz" records the full extent.
/// Transform: scale = spacing, translation = origin. Metadata as string metadata.
/// Written to a temporary file in the same directory, then renamed over `path`.
void write_vdb(const Volume& volume, const std::string& path);

/// The same from planes read one after the other (streaming decode): the grid
/// is built plane by plane (the planes are read once more first when the grid
/// type depends on every value: a u32 volume read from an int32 grid, say), so
/// memory holds the grid and one plane, not a dense copy besides. The same
/// grid, metadata and transform as write_vdb on the whole volume.
void write_vdb(VolumePlanes& planes, const std::string& path);

/// The metadata keys write_vdb leaves out, in key order.
std::vector<std::string> vdb_unstorable_keys(const Volume& volume);

}  // namespace tetlod
