#pragma once
// Checks that keep hostile HDF5 files away from libhdf5 (or from large
// allocations) before the reader trusts them. Private to tetlod_hdf5_io.
//  - check_hdf5_superblock: own parser, no library: the signature (at 0, 512,
//    1024, ... for files with a user block) and the superblock's version and
//    address/length sizes. Runs in the calling process.
//  - make_safe_dataset_access: a dataset/link access property list on which
//    external links are refused before the target file is opened, and external
//    raw-data files resolve next to the HDF5 file, not the working directory.
//  - check_dataset_claims: a dataset's declared bytes against the bytes it
//    stores: virtual datasets refused, external raw-data files vetted (regular
//    files inside the HDF5 file's folder, holding the declared bytes), chunked
//    datasets bounded by the stored chunk bytes x the largest compression ratio.
#include <hdf5.h>

#include <cstdint>
#include <string>

namespace tetlod::hdf5_guard {

/// Largest expansion of stored chunk bytes tetlod accepts (deflate's bound is 1032).
inline constexpr uint64_t kMaxCompressionRatio = 1100;
/// Samples a chunked dataset may declare beyond that bound (unwritten chunks).
inline constexpr uint64_t kUnstoredAllowanceBytes = uint64_t{1} << 20;

/// Throws BadMagic / UnsupportedVersion / Truncated naming `file`.
void check_hdf5_superblock(const std::string& file, uint64_t file_size);

/// Owned by the caller (H5Pclose).
hid_t make_safe_dataset_access(const std::string& file);

/// Throws TooLarge / Truncated / UnsupportedFeature / IoError naming `what`.
void check_dataset_claims(hid_t dataset, hid_t dcpl, uint64_t declared_bytes, uint64_t element_bytes,
                          const std::string& file, uint64_t file_size, const std::string& what);

}  // namespace tetlod::hdf5_guard
