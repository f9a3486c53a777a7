#pragma once
// Private helpers shared by the NRRD and MetaImage converters: moving samples
// between a volume and one or more data files, raw or zlib/gzip-compressed, in
// either byte order, through bounded buffers. Not a public header.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

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

/// Reads the samples of a dims x type volume from the pieces, which share them
/// equally in order, and returns the volume (geometry left at its defaults).
/// Never allocates what the header merely claims: each file's size is checked
/// first (raw data: exactly; compressed: the deflate bound), and compressed
/// samples go into a buffer that grows only as the stream produces them, so a
/// garbage or short stream fails before its claimed size is allocated. Swaps
/// bytes when `file_endian` is not the host order. `what` names the header
/// file in errors. Throws tetlod::Error (IoError, Truncated, SizeMismatch,
/// CorruptData).
Volume read_samples(const Dims& dims, ValueType type, const std::vector<DataPiece>& pieces,
                    Compression compression, Endian file_endian, const std::string& what);

/// The planes of `header` (dims, type, geometry, metadata): one uncompressed
/// piece without line skip read by offset (open_raw_planes_at), any other
/// layout by open_piece_planes (several files, line skip, compressed streams).
/// The sizes are checked first.
std::unique_ptr<VolumePlanes> planes_of_pieces(Volume header, const std::vector<DataPiece>& pieces,
                                               Compression compression, Endian file_endian, const std::string& what);
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
/// The same from planes read one after the other (memory: one plane and the buffers).
uint64_t write_samples(AtomicFile& out, VolumePlanes& planes, Endian endian, Compression compression,
                       bool gzip_wrapper);

// Data file access, shared by the whole reader and the plane reader.
inline constexpr std::size_t kIoChunk = std::size_t{4} << 20;   // bytes read or written per call
inline constexpr std::size_t kZChunk = std::size_t{256} << 10;  // compressed bytes per call
struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;
Endian host_endian();
void swap_bytes(std::byte* p, std::size_t bytes, std::size_t width);
/// Size of a data file (a regular file, else IoError naming `what`).
uint64_t file_size_of(const std::string& path, const std::string& what);
/// Opens a data file for reading (regular files only) and notes it as an input of this run.
FilePtr open_read(const std::string& path, const std::string& what);
void seek_to(std::FILE* f, uint64_t pos, const std::string& path);
/// Skips `lines` newline-terminated lines from `pos`; returns the new position
/// (Truncated when the file ends first).
uint64_t skip_lines(std::FILE* f, int64_t lines, uint64_t pos, const std::string& path, const std::string& what);
/// Where `bytes` of raw samples of `piece` start, `pos` being the position after
/// its line skip and `size` the file's size (byte skip -1: the last bytes).
/// Truncated naming the file when it cannot hold them.
uint64_t raw_piece_start(uint64_t pos, uint64_t size, const DataPiece& piece, uint64_t bytes,
                         const std::string& what);

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
/// The data file a header names, resolved beside the header. A name that leaves
/// the header's folder (an absolute path elsewhere, or ".." components) is
/// refused with UnsupportedFeature unless `allow_external` (the user's
/// --allow-external-data): a header must not make tetlod read arbitrary files.
std::string resolve_data_file(const std::string& header_path, const std::string& name, bool allow_external,
                              const std::string& what);
/// Number of files of a "FORMAT MIN MAX STEP" data file pattern, computed
/// without overflow; refuses an empty or endless range (CorruptData) and more
/// than `max_files` files (TooLarge). `field` names the header field.
int64_t pattern_file_count(int64_t lo, int64_t hi, int64_t step, int64_t max_files, const std::string& what,
                           const std::string& field);
/// Refuses non-finite or non-positive spacing and non-finite origin
/// (CorruptData naming `what` and `field`): the container could not store them.
void check_geometry(const Vec3& spacing, const Vec3& origin, const std::string& what);
/// printf-style "%d" pattern with one integer conversion (flags/width allowed).
std::string format_file_pattern(const std::string& pattern, int64_t n, const std::string& what);

}  // namespace tetlod::detail
