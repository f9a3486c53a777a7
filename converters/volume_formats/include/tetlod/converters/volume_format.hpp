#pragma once
// The table of volume formats: one VolumeFormat entry per format, registered in
// one list (src/volume_format_registry.cpp). The dispatcher (volume_formats.hpp),
// the CLI's help texts and its --format choices are all generated from this
// table, so adding a format means writing its reader/writer and its entry
// (src/formats/<name>_format.cpp) plus one line in the registration list.
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

struct VolumeFormat;

/// Where a user-given name points: format, file on disk and, for formats with
/// datasets (HDF5: FILE.h5:/path), the dataset inside the file.
struct VolumeLocation {
    const VolumeFormat* format = nullptr;  // an entry of volume_formats(), never null once located
    std::string file;                      // the file on disk
    std::string dataset;                   // formats with datasets only: path inside the file
    std::string format_name;               // the --format name given (lower case), or "" (from the extension)
};

struct VolumeFormat {
    /// Canonical name, also accepted by --format ("nrrd").
    std::string name;
    /// Other names --format accepts ("nhdr", "openvdb"); they may pick a variant
    /// (the writer sees them in VolumeLocation::format_name).
    std::vector<std::string> aliases;
    /// Lower-case file extensions with the dot (".nrrd", ".nhdr"), matched
    /// case-insensitively at the end of the name.
    std::vector<std::string> extensions;
    /// One line for help texts ("NRRD, attached .nrrd or detached .nhdr").
    std::string description;
    /// False when this build leaves the format out: read/write are then empty
    /// and the dispatcher throws ErrorCode::NotBuilt, naming `not_built_hint`.
    bool built = true;
    std::string not_built_hint;
    /// Names are FILE.ext:/dataset (the dataset part may contain ':' or '.').
    bool datasets = false;

    std::function<Volume(const VolumeLocation&, const VolumeReadOptions&)> read;
    /// Optional: the volume read plane by plane, each plane read when asked
    /// (out-of-core conversion). Empty: the format is only read whole.
    std::function<std::unique_ptr<VolumePlanes>(const VolumeLocation&, const VolumeReadOptions&)> open_planes;
    /// Writes atomically: nothing is left at the target if writing fails.
    std::function<void(const Volume&, const VolumeLocation&)> write;
    /// Optional: `write` from planes read one after the other (streaming decode):
    /// the same bytes, one plane in memory. Empty: the volume is written whole.
    std::function<void(VolumePlanes&, const VolumeLocation&)> write_planes;
    /// Metadata keys of the volume that `write` leaves out (empty: none).
    std::function<std::vector<std::string>(const Volume&)> lost_metadata;
    /// Optional: other files `write` creates beside `file` (a detached header's data file).
    std::function<std::vector<std::string>(const VolumeLocation&)> companion_files;
    /// Optional: refuses, before any work, what `write` would refuse at the end
    /// under the installed OutputPolicy (HDF5: an existing dataset without
    /// force, a group at the dataset's path). Throws like `write` would.
    std::function<void(const VolumeLocation&)> check_output;
    /// Optional: true when a file whose extension no format knows is still this
    /// format (raw: when its dims and type are known from the options or the name).
    std::function<bool(const std::string& path, const VolumeReadOptions&)> claims_unknown_name;
};

/// Every format, built or not, in registration order: the built-in list, then
/// those added with register_volume_format. Entries never move.
const std::deque<VolumeFormat>& volume_formats();

/// Adds a format to the table (a third party's, or a test's). Not thread-safe:
/// call it before any thread reads or writes volumes. Throws InvalidArgument
/// when its name, an alias or an extension is already taken.
void register_volume_format(VolumeFormat format);

/// The entry named `name` (canonical name or alias, case-insensitive), or null.
const VolumeFormat* find_volume_format(const std::string& name);

/// True when this build can read and write the format named `name`.
bool volume_format_built(const std::string& name);

/// Every name --format accepts (names and aliases).
std::vector<std::string> volume_format_names();

/// The file names of every format, for help texts and messages:
/// ".raw, .nrrd/.nhdr, .mha/.mhd, .vdb, FILE.h5:/dataset" (formats this build
/// leaves out are marked "(not built)").
std::string volume_format_summary();

}  // namespace tetlod
