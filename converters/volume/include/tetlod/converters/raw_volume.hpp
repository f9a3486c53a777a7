#pragma once
// Headerless raw volumes: dims.x * dims.y * dims.z samples of one scalar type,
// x varying fastest, then y, then z, optionally after a fixed-size header that is
// skipped. Dims and type come from the options or, where absent, from a file name
// of the form NAME_XxYxZ_DTYPE.raw (e.g. bucky_32x32x32_uint8.raw).
#include <memory>
#include <optional>
#include <string>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

/// Dims and type encoded in a file name NAME_XxYxZ_DTYPE[.ext] (any directory,
/// any extension). Empty when the name does not follow the convention.
struct RawNameInfo {
    Dims dims;
    ValueType type = ValueType::U8;
};
std::optional<RawNameInfo> parse_raw_volume_name(const std::string& path);

/// Reads a raw volume. Dims and type from `options` win over the file name.
/// Checks, before allocating anything: dims valid (validate_dims) and at least 2
/// along each axis (a 3D mesh needs 2 samples per axis), and file size ==
/// header_bytes + dims.count() * value_size(type) (ErrorCode::SizeMismatch naming
/// the file, expected and actual sizes). Big-endian input is swapped to host order.
/// Reads in bounded slabs straight into the volume. Safe on untrusted input.
/// Sets spacing/origin from the options and metadata["source_file"] to the file name.
Volume read_raw_volume(const std::string& path, const VolumeReadOptions& options);

/// The same file read plane by plane (by offset, nothing kept): the same
/// checks first, then each read() costs what it reads.
std::unique_ptr<VolumePlanes> open_raw_volume_planes(const std::string& path, const VolumeReadOptions& options);

/// Planes of `header`'s dims and type stored raw in `path` from byte `offset`
/// (x fastest, in `endian` byte order), read by offset: the data block of a
/// NRRD or MetaImage file. Checks the file holds them first.
std::unique_ptr<VolumePlanes> open_raw_planes_at(const std::string& path, uint64_t offset, Volume header,
                                                 Endian endian);

/// Writes the samples of planes read one after the other, atomically.
void write_raw_volume(VolumePlanes& planes, const std::string& path, Endian endian = Endian::Little);

/// Writes the samples (no header) in the given byte order, atomically (the target
/// is replaced only once the whole file is on disk). Throws tetlod::Error(IoError).
void write_raw_volume(const Volume& volume, const std::string& path,
                      Endian endian = Endian::Little);

}  // namespace tetlod
