#pragma once
// NRRD volumes (http://teem.sourceforge.net/nrrd/format.html), attached (.nrrd:
// header then data in one file) and detached (.nhdr: header naming one or more
// data files).
//
// Read: NRRD0001..NRRD0005 headers of dimension 1..3 (missing axes get size 1).
//  - types: every 8/16/32-bit integer and float/double spelling of the spec;
//    64-bit integers and "block" are refused (tetlod volumes hold no such type).
//  - encodings raw and gzip (gz); txt/hex/bzip2 give ErrorCode::UnsupportedFeature.
//  - endian, byte skip (-1 = data at the end of the file, raw only), line skip.
//  - geometry: "spacings", or "space directions" when every direction is a
//    positive multiple of its own axis (an axis-aligned frame). A rotated,
//    permuted or flipped frame is refused with UnsupportedFeature: tetlod grids
//    are axis-aligned and silently dropping the rotation would misplace the data.
//    "space origin" becomes Volume::origin.
//  - "data file": a single name, LIST (names on the following lines) or a
//    "FORMAT MIN MAX STEP [SUBDIM]" pattern; the files share the samples equally.
//    Data files must lie in the header's folder unless
//    VolumeReadOptions::allow_external_data (refused: UnsupportedFeature).
//  - "key:=value" pairs go to Volume::metadata unchanged (\n and \\ unescaped);
//    "content" becomes Volume::field_name, "sample units" Volume::units, other
//    informative fields (space, kinds, labels, units, ...) metadata "nrrd:<field>".
// Every size the header claims is checked against the data files before the
// volume is allocated; the data are read through bounded buffers. Safe on
// untrusted input: every problem is a tetlod::Error naming the file.
#include <memory>
#include <string>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

/// Reads a .nrrd or .nhdr file. Spacing/origin in `options` override the file.
Volume read_nrrd(const std::string& path, const VolumeReadOptions& options = {});

struct NrrdWriteOptions {
    bool gzip = false;
    Endian endian = Endian::Little;
    /// Detached header: the samples go to a file beside the header named after it
    /// (OUT.raw or OUT.raw.gz). Default: detached when the path ends in .nhdr.
    enum class Layout { Auto, Attached, Detached } layout = Layout::Auto;
};

/// Writes NRRD0004 with a diagonal "space directions" (the spacing) and "space
/// origin", the field name as "content", units as "sample units" and every
/// metadata entry as a key/value pair; "nrrd:space", "nrrd:kinds", "nrrd:centers"
/// and "nrrd:space units" are written back as those fields when they fit 3 axes.
/// A metadata key NRRD cannot hold (empty, ":=" or a line break) is left out,
/// never refused: callers report nrrd_unstorable_keys(). Each file is written
/// atomically; a detached header is written after its data.
void write_nrrd(const Volume& volume, const std::string& path, const NrrdWriteOptions& options = {});
/// The same file read plane by plane, by offset, when its samples are one
/// uncompressed block (raw encoding, one data file, no line skip); null for any
/// other layout (gzip, several files), which read_nrrd reads whole. The same
/// header checks first.
std::unique_ptr<VolumePlanes> open_nrrd_planes(const std::string& path, const VolumeReadOptions& options);
/// The same from planes read one after the other (the header from planes.header()).
void write_nrrd(VolumePlanes& planes, const std::string& path, const NrrdWriteOptions& options = {});

/// The metadata keys write_nrrd leaves out, in key order.
std::vector<std::string> nrrd_unstorable_keys(const Volume& volume);

}  // namespace tetlod
