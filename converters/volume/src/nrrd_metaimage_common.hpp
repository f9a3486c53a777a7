#pragma once
// Private helpers shared by the NRRD and MetaImage converters: moving samples
// between a volume and one or more data files, raw or zlib/gzip-compressed, in
// either byte order, through bounded buffers. Not a public header.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::detail {

enum class Compression { None, Deflate /* gzip or zlib stream, detected from its header */ };

/// One data file holding a contiguous part of the samples.
struct DataPiece {
    std::string path;
    /// Bytes of the file to skip before the data (the attached header), applied
    /// before decompression.
    uint64_t file_offset = 0;
    /// Lines to skip after file_offset (NRRD "line skip"), before decompression.
    int64_t line_skip = 0;
    /// Bytes to skip: for raw data counted from the file position after line
    /// skip; for compressed data counted in the decompressed stream. -1 (raw only):
    /// the data are the last bytes of the file.
    int64_t byte_skip = 0;
};

/// Largest ratio of deflate output to input (RFC 1951: 258 bytes per 2-bit code
/// plus block overhead); used to refuse a header that claims more data than a
/// compressed file can hold before allocating for it.
inline constexpr uint64_t kMaxDeflateRatio = 1032;

/// Fills `volume.data` (already allocated for dims x type) from the pieces, which
/// share the samples equally in order. Checks each file's size before reading;
/// swaps bytes when `file_endian` is not the host order. `what` names the
/// header file in errors. Throws tetlod::Error (IoError, Truncated, SizeMismatch,
/// CorruptData).
void read_samples(Volume& volume, const std::vector<DataPiece>& pieces, Compression compression,
                  Endian file_endian, const std::string& what);

/// Throws Truncated/SizeMismatch when the pieces cannot hold `total_bytes` of
/// samples (raw: exact sizes; compressed: the deflate bound). Call before
/// allocating the volume.
void check_piece_sizes(const std::vector<DataPiece>& pieces, Compression compression,
                       uint64_t total_bytes, const std::string& what);

/// Appends the samples of `volume` to `out` in `endian` byte order, raw or
/// compressed (gzip wrapper when `gzip`, zlib wrapper otherwise), through a
/// bounded buffer. Returns the number of bytes appended.
uint64_t write_samples(AtomicFile& out, const Volume& volume, Endian endian, Compression compression,
                       bool gzip_wrapper);

// Small text helpers.
std::string trim(std::string_view s);
std::string to_lower(std::string_view s);
std::vector<std::string> split_ws(std::string_view s);
/// Parses a double ("nan" and "inf" accepted); throws CorruptData naming `what`.
double parse_double(const std::string& s, const std::string& what);
int64_t parse_int(const std::string& s, const std::string& what);
/// Shortest text that parses back to exactly the same double.
std::string format_double(double v);
/// Directory part of a path ("" for none) joined with a relative file name;
/// absolute names are returned unchanged.
std::string resolve_beside(const std::string& header_path, const std::string& name);
/// printf-style "%d" pattern with one integer conversion (flags/width allowed).
std::string format_file_pattern(const std::string& pattern, int64_t n, const std::string& what);

}  // namespace tetlod::detail
