#pragma once
// One entry point for every volume format tetlod reads and writes, chosen from
// the file name:
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
#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

enum class VolumeFormat { Raw, Nrrd, MetaImage, Vdb, Hdf5 };

struct VolumeLocation {
    VolumeFormat format = VolumeFormat::Raw;
    std::string file;     // the file on disk
    std::string dataset;  // HDF5 only: path inside the file
};

/// Splits a user-given name into format, file and HDF5 dataset. `format`
/// (raw, nrrd, nhdr, mhd, mha, vdb, h5, hdf5) overrides the extension.
/// Throws InvalidArgument for an unknown extension.
VolumeLocation locate_volume(const std::string& path, const std::string& format = "");

/// True when this build can read and write `format`.
bool volume_format_built(VolumeFormat format);

/// Reads any supported volume. A name with no known extension is read as raw
/// when options give dims and type or the name is NAME_XxYxZ_DTYPE.ext.
/// Throws tetlod::Error naming the file and problem.
Volume read_volume(const std::string& path, const VolumeReadOptions& options = {});

/// Writes `volume` in the format chosen by `path` (or `format`), atomically:
/// nothing is left at the target if writing fails.
void write_volume(const Volume& volume, const std::string& path, const std::string& format = "");

/// The metadata keys of `volume` that write_volume(volume, path, format) leaves
/// out because the format cannot hold them (raw: every key; the others: keys
/// their syntax cannot express). Writers never refuse such metadata; callers
/// report these keys (tetlod prints a warning naming them).
std::vector<std::string> metadata_keys_lost(const Volume& volume, const std::string& path,
                                            const std::string& format = "");

}  // namespace tetlod
