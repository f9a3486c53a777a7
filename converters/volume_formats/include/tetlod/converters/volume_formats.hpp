#pragma once
// One entry point for every volume format tetlod reads and writes, chosen from
// the file name through the table of formats (volume_format.hpp); see
// volume_format_summary() for the list. The built-in formats:
//   .raw                     raw samples (dims/type from options or NAME_XxYxZ_DTYPE.raw)
//   .nrrd / .nhdr            NRRD, attached / detached
//   .mha / .mhd              MetaImage, attached / detached
//   .vdb                     OpenVDB (VolumeReadOptions::grid picks the grid)
//   FILE.h5:/path, FILE.hdf5:/path   HDF5 dataset (default /volume when no path)
// A format left out of this build (TETLOD_WITH_OPENVDB / TETLOD_WITH_HDF5 off)
// gives ErrorCode::NotBuilt; an unknown extension ErrorCode::InvalidArgument.
#include <string>
#include <vector>

#include "tetlod/converters/features.hpp"
#include "tetlod/converters/volume_format.hpp"
#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

/// Splits a user-given name into format, file and dataset. `format` (any of
/// volume_format_names()) overrides the extension. Throws InvalidArgument for
/// an unknown extension or format name.
VolumeLocation locate_volume(const std::string& path, const std::string& format = "");

/// Reads any supported volume. A name with no known extension is read by the
/// format that claims it (raw, when options give dims and type or the name is
/// NAME_XxYxZ_DTYPE.ext). Throws tetlod::Error naming the file and problem.
Volume read_volume(const std::string& path, const VolumeReadOptions& options = {});

/// The volume read plane by plane when its format can (raw; see
/// VolumeFormat::open_planes), else null: read_volume then reads it whole.
/// The same checks and errors as read_volume before anything is read.
std::unique_ptr<VolumePlanes> open_volume_planes(const std::string& path, const VolumeReadOptions& options = {});
/// Writes `volume` in the format chosen by `path` (or `format`), atomically:
/// nothing is left at the target if writing fails.
void write_volume(const Volume& volume, const std::string& path, const std::string& format = "");

/// True when the format `path` (or `format`) names writes plane by plane.
bool volume_format_writes_planes(const std::string& path, const std::string& format = "");
/// write_volume from planes read one after the other (one plane in memory)
/// where the format can (volume_format_writes_planes); else the planes are
/// read into a volume first. Same bytes either way.
void write_volume(VolumePlanes& planes, const std::string& path, const std::string& format = "");
/// The metadata keys of `volume` that write_volume(volume, path, format) leaves
/// out because the format cannot hold them (raw: every key; the others: keys
/// their syntax cannot express). Writers never refuse such metadata; callers
/// report these keys (tetlod prints a warning naming them).
std::vector<std::string> metadata_keys_lost(const Volume& volume, const std::string& path,
                                            const std::string& format = "");

/// Files write_volume(volume, path, format) creates besides the named one (the
/// data file of a detached header); empty for most formats or an unknown name.
std::vector<std::string> volume_companion_files(const std::string& path, const std::string& format = "");

/// The format's check_output for `path`, if it has one: refuses up front an
/// output write_volume would refuse after the work (see VolumeFormat).
void check_volume_output(const std::string& path, const std::string& format = "");

}  // namespace tetlod
