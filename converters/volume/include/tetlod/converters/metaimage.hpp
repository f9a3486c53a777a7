#pragma once
// MetaImage volumes (ITK/VTK MetaIO, https://itk.org/Wiki/ITK/MetaIO/Documentation):
// .mha (header and data in one file, ElementDataFile = LOCAL) and .mhd (header
// naming a separate data file).
//
// Read: "Key = Value" lines up to ElementDataFile (which ends the header).
//  - NDims 1..3 (missing axes get size 1), DimSize, ElementType MET_CHAR/UCHAR/
//    SHORT/USHORT/INT/UINT/LONG/ULONG (32-bit)/FLOAT/DOUBLE; 64-bit types,
//    ASCII data (BinaryData = False) and several channels are refused with
//    ErrorCode::UnsupportedFeature.
//  - ElementSpacing (else ElementSize) -> spacing; Offset (or Position/Origin)
//    -> origin; TransformMatrix (or Rotation/Orientation) must be the identity:
//    a rotated frame is refused with UnsupportedFeature (tetlod grids are
//    axis-aligned).
//  - BinaryDataByteOrderMSB / ElementByteOrderMSB, HeaderSize (-1 = the data are
//    the last bytes of the file), CompressedData (zlib), CompressedDataSize.
//  - ElementDataFile: LOCAL, a file name (relative to the header), LIST [subdim]
//    (names on the following lines) or "FORMAT MIN MAX STEP [SUBDIM]"; data files
//    must lie in the header's folder unless VolumeReadOptions::allow_external_data.
//  - Offset and ElementSpacing must be finite (a container cannot store others).
//  - Name becomes Volume::field_name, "units" Volume::units; every other field
//    not listed above is kept in Volume::metadata under its own key (values with
//    "\n" and "\\" unescaped, the escaping tetlod's writer applies).
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

/// Reads a .mha or .mhd file. Spacing/origin in `options` override the file.
Volume read_metaimage(const std::string& path, const VolumeReadOptions& options = {});

struct MetaImageWriteOptions {
    bool compress = false;  // CompressedData = True (zlib)
    Endian endian = Endian::Little;
    /// Detached: data go beside the header as STEM.raw (STEM.zraw when
    /// compressed). Default: detached when the path ends in .mhd.
    enum class Layout { Auto, Attached, Detached } layout = Layout::Auto;
};

/// Writes the volume with identity TransformMatrix, Offset, ElementSpacing,
/// Name (field name), "units" and each metadata entry as its own field. A
/// metadata key MetaImage cannot hold (empty, white space, '=', or a MetaIO
/// field name such as "nrrd:space units") is left out, never refused: callers
/// report metaimage_unstorable_keys(). Each file is written atomically; a
/// detached header after its data.
void write_metaimage(const Volume& volume, const std::string& path, const MetaImageWriteOptions& options = {});
/// The same file read plane by plane, by offset, when its samples are one
/// uncompressed block (one data file); null for any other layout (compressed,
/// several files), which read_metaimage reads whole. The same header checks first.
std::unique_ptr<VolumePlanes> open_metaimage_planes(const std::string& path, const VolumeReadOptions& options);
/// The same from planes read one after the other (the header from planes.header()).
void write_metaimage(VolumePlanes& planes, const std::string& path, const MetaImageWriteOptions& options = {});

/// The metadata keys write_metaimage leaves out, in key order.
std::vector<std::string> metaimage_unstorable_keys(const Volume& volume);

}  // namespace tetlod
