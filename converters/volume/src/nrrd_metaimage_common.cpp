#include "nrrd_metaimage_common.hpp"

#include "piece_planes.hpp"

#include "tetlod/converters/raw_volume.hpp"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string_view>

#include "tetlod/core/error.hpp"
#include "tetlod/core/regular_file.hpp"
#include "tetlod/core/output_policy.hpp"

namespace tetlod::detail {

Endian host_endian() { return std::endian::native == std::endian::little ? Endian::Little : Endian::Big; }

void swap_bytes(std::byte* p, std::size_t bytes, std::size_t width) {
    if (width == 1) return;
    for (std::size_t i = 0; i + width <= bytes; i += width) std::reverse(p + i, p + i + width);
}

uint64_t file_size_of(const std::string& path, const std::string& what) {
    require_regular_file(path, "data file of " + what);
    std::error_code ec;
    auto size = std::filesystem::file_size(path, ec);
    if (ec)
        throw Error(ErrorCode::IoError, what + ": cannot open data file '" + path + "': " + ec.message());
    return size;
}

FilePtr open_read(const std::string& path, const std::string& what) {
    require_regular_file(path, "data file of " + what);
    note_input_file(path);  // a data file of a detached header: never an output of this run
    FilePtr f(std::fopen(path.c_str(), "rb"));
    if (!f)
        throw Error(ErrorCode::IoError,
                    what + ": cannot open data file '" + path + "': " + std::strerror(errno));
    return f;
}

void seek_to(std::FILE* f, uint64_t pos, const std::string& path) {
    if (::fseeko(f, static_cast<off_t>(pos), SEEK_SET) != 0)
        throw Error(ErrorCode::IoError, "cannot seek in '" + path + "': " + std::strerror(errno));
}

// Skips `lines` newline-terminated lines; returns the new position.
uint64_t skip_lines(std::FILE* f, int64_t lines, uint64_t pos, const std::string& path,
                    const std::string& what) {
    for (int64_t l = 0; l < lines; ++l) {
        int c;
        while ((c = std::fgetc(f)) != EOF && c != '\n') ++pos;
        if (c == EOF)
            throw Error(ErrorCode::Truncated, what + ": data file '" + path + "' ends within the " +
                                                  std::to_string(lines) + " lines to skip");
        ++pos;
    }
    return pos;
}

uint64_t raw_piece_start(uint64_t pos, uint64_t size, const DataPiece& piece, uint64_t bytes,
                         const std::string& what) {
    uint64_t start = pos;
    if (piece.byte_skip == -1) {
        if (size < bytes || size - bytes < pos)
            throw Error(ErrorCode::Truncated,
                        what + ": data file '" + piece.path + "' holds " + std::to_string(size) +
                            " bytes, fewer than the " + std::to_string(bytes) + " the header declares");
        start = size - bytes;
    } else {
        start = pos + static_cast<uint64_t>(piece.byte_skip);
    }
    if (start > size || size - start < bytes)
        throw Error(ErrorCode::Truncated,
                    what + ": data file '" + piece.path + "' is truncated: " +
                        std::to_string(start > size ? 0 : size - start) + " bytes of data after offset " +
                        std::to_string(start) + ", but the header declares " + std::to_string(bytes));
    return start;
}

namespace {

void read_raw_piece(std::FILE* f, uint64_t pos, uint64_t size, const DataPiece& piece,
                    std::byte* out, uint64_t bytes, const std::string& what) {
    const uint64_t start = raw_piece_start(pos, size, piece, bytes, what);
    seek_to(f, start, piece.path);
    for (uint64_t done = 0; done < bytes;) {
        std::size_t n = static_cast<std::size_t>(std::min<uint64_t>(kIoChunk, bytes - done));
        if (std::fread(out + done, 1, n, f) != n)
            throw Error(ErrorCode::Truncated, what + ": cannot read data file '" + piece.path +
                                                  "' (ended or failed at byte " +
                                                  std::to_string(start + done) + ")");
        done += n;
    }
}

/// Grows `buf` so it holds at least `need` bytes, geometrically but never past
/// `cap` (the size the header declares): memory follows the data produced.
void grow_to(ZeroedVector<std::byte>& buf, uint64_t need, uint64_t cap) {
    if (need <= buf.size()) return;
    if (need > buf.capacity())
        buf.reserve(static_cast<std::size_t>(std::min<uint64_t>(cap, std::max<uint64_t>(need, 2 * buf.capacity()))));
    buf.resize(static_cast<std::size_t>(need));
}

/// Inflates `bytes` samples of one piece and appends them to `out` (whose final
/// size is `cap`), growing it only as the stream yields data.
void inflate_piece(std::FILE* f, const DataPiece& piece, ZeroedVector<std::byte>& out, uint64_t bytes,
                   uint64_t cap, const std::string& what) {
    z_stream zs{};
    if (inflateInit2(&zs, 15 + 32) != Z_OK)
        throw Error(ErrorCode::IoError, what + ": cannot initialise zlib");
    struct Guard {
        z_stream* z;
        ~Guard() { inflateEnd(z); }
    } guard{&zs};
    std::vector<unsigned char> in(kZChunk);
    std::vector<unsigned char> skip(std::min<uint64_t>(kZChunk, std::max<int64_t>(piece.byte_skip, 4096)));
    uint64_t to_skip = piece.byte_skip > 0 ? static_cast<uint64_t>(piece.byte_skip) : 0;
    const uint64_t base = out.size();
    uint64_t done = 0;
    bool stream_end = false;
    auto corrupt = [&](const char* msg) {
        return Error(ErrorCode::CorruptData, what + ": compressed data in '" + piece.path +
                                                 "' is corrupt (" + (msg ? msg : "zlib error") + ")");
    };
    while (done < bytes) {
        if (zs.avail_in == 0) {
            std::size_t n = std::fread(in.data(), 1, in.size(), f);
            if (n == 0)
                throw Error(ErrorCode::Truncated,
                            what + ": data file '" + piece.path + "' is truncated: it decompresses to " +
                                std::to_string(done) + " bytes, but the header declares " +
                                std::to_string(bytes));
            zs.next_in = in.data();
            zs.avail_in = static_cast<uInt>(n);
        }
        if (stream_end) {  // a following gzip member (concatenated streams)
            if (inflateReset(&zs) != Z_OK) throw corrupt(zs.msg);
            stream_end = false;
        }
        const uint64_t want = std::min<uint64_t>(kZChunk, bytes - done);
        if (to_skip > 0) {
            zs.next_out = skip.data();
            zs.avail_out = static_cast<uInt>(std::min<uint64_t>(skip.size(), to_skip));
        } else {
            grow_to(out, base + done + want, cap);
            zs.next_out = reinterpret_cast<Bytef*>(out.data() + base + done);
            zs.avail_out = static_cast<uInt>(want);
        }
        uInt before = zs.avail_out;
        int rc = inflate(&zs, Z_NO_FLUSH);
        if (rc == Z_STREAM_END) {
            stream_end = true;
        } else if (rc != Z_OK && rc != Z_BUF_ERROR) {
            throw corrupt(zs.msg);
        }
        uint64_t produced = before - zs.avail_out;
        if (to_skip > 0) to_skip -= produced;
        else done += produced;
        if (!(to_skip > 0)) out.resize(static_cast<std::size_t>(base + done));
    }
    // All samples are in; run the stream to its end so the trailer's checksum
    // (CRC-32 for gzip, Adler-32 for zlib) is verified and a cut-off file is
    // caught. Any data past the declared samples are decoded and ignored.
    while (!stream_end) {
        if (zs.avail_in == 0) {
            std::size_t n = std::fread(in.data(), 1, in.size(), f);
            if (n == 0)
                throw Error(ErrorCode::Truncated, what + ": data file '" + piece.path +
                                                      "' is truncated: the compressed stream has no end");
            zs.next_in = in.data();
            zs.avail_in = static_cast<uInt>(n);
        }
        zs.next_out = skip.data();
        zs.avail_out = static_cast<uInt>(skip.size());
        int rc = inflate(&zs, Z_NO_FLUSH);
        if (rc == Z_STREAM_END) stream_end = true;
        else if (rc != Z_OK && rc != Z_BUF_ERROR) throw corrupt(zs.msg);
    }
}

}  // namespace

void check_piece_sizes(const std::vector<DataPiece>& pieces, Compression compression,
                       uint64_t total_bytes, const std::string& what) {
    if (pieces.empty()) throw Error(ErrorCode::CorruptData, what + ": no data file");
    if (total_bytes % pieces.size() != 0)
        throw Error(ErrorCode::SizeMismatch,
                    what + ": " + std::to_string(total_bytes) + " bytes of samples cannot be split evenly over " +
                        std::to_string(pieces.size()) + " data files");
    const uint64_t per = total_bytes / pieces.size();
    for (const auto& p : pieces) {
        uint64_t size = file_size_of(p.path, what);
        uint64_t avail = size > p.file_offset ? size - p.file_offset : 0;
        if (compression == Compression::None) {
            uint64_t need = per + (p.byte_skip > 0 ? static_cast<uint64_t>(p.byte_skip) : 0);
            if (avail < need)
                throw Error(ErrorCode::Truncated,
                            what + ": data file '" + p.path + "' is truncated: it holds " + std::to_string(avail) +
                                " bytes of data, but the header declares " + std::to_string(need));
        } else {
            uint64_t need = per + (p.byte_skip > 0 ? static_cast<uint64_t>(p.byte_skip) : 0);
            if (avail == 0 || need / kMaxDeflateRatio > avail)
                throw Error(ErrorCode::Truncated,
                            what + ": data file '" + p.path + "' holds " + std::to_string(avail) +
                                " compressed bytes, too few to decompress to the " + std::to_string(need) +
                                " bytes the header declares");
        }
    }
}

std::unique_ptr<VolumePlanes> planes_of_pieces(Volume header, const std::vector<DataPiece>& pieces,
                                               Compression compression, Endian file_endian, const std::string& what) {
    validate_dims(header.dims, what);
    const uint64_t total = static_cast<uint64_t>(header.dims.count()) * value_size(header.type);
    check_piece_sizes(pieces, compression, total, what);
    if (compression != Compression::None || pieces.size() != 1 || pieces[0].line_skip != 0)
        return open_piece_planes(std::move(header), pieces, compression, file_endian, what);
    const DataPiece& p = pieces[0];
    // byte skip -1: the samples are the file's last bytes.
    const uint64_t offset = p.byte_skip >= 0 ? p.file_offset + uint64_t(p.byte_skip)
                                             : file_size_of(p.path, what) - total;
    return open_raw_planes_at(p.path, offset, std::move(header), file_endian);
}

Volume read_samples(const Dims& dims, ValueType type, const std::vector<DataPiece>& pieces,
                    Compression compression, Endian file_endian, const std::string& what) {
    validate_dims(dims, what);
    const uint64_t total = static_cast<uint64_t>(dims.count()) * value_size(type);
    check_piece_sizes(pieces, compression, total, what);  // before allocating anything
    const uint64_t per = total / pieces.size();
    Volume vol;
    vol.dims = dims;
    vol.type = type;
    // Raw data: every file holds its bytes (just checked), so the claim is backed.
    if (compression == Compression::None) vol.data.resize(static_cast<std::size_t>(total));
    for (std::size_t i = 0; i < pieces.size(); ++i) {
        const DataPiece& piece = pieces[i];
        uint64_t size = file_size_of(piece.path, what);
        FilePtr f = open_read(piece.path, what);
        seek_to(f.get(), piece.file_offset, piece.path);
        uint64_t pos = skip_lines(f.get(), piece.line_skip, piece.file_offset, piece.path, what);
        if (compression == Compression::None) {
            read_raw_piece(f.get(), pos, size, piece, vol.data.data() + i * per, per, what);
        } else {
            if (piece.byte_skip < 0)
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": \"byte skip: -1\" is only allowed with raw encoding");
            inflate_piece(f.get(), piece, vol.data, per, total, what);
        }
    }
    if (file_endian != host_endian()) swap_bytes(vol.data.data(), vol.data.size(), value_size(type));
    return vol;
}

namespace {

/// The samples of a volume's planes as one byte stream, a plane in memory at a time.
class PlaneBytes {
public:
    explicit PlaneBytes(VolumePlanes& planes)
        : planes_(planes),
          plane_(std::size_t(planes.header().dims.x * planes.header().dims.y) * value_size(planes.header().type)) {}
    uint64_t total() const { return uint64_t(plane_.size()) * uint64_t(planes_.header().dims.z); }
    /// Copies the next n bytes (n <= what is left) to dst.
    void next(std::byte* dst, std::size_t n) {
        while (n > 0) {
            if (at_ == plane_.size() || z_ < 0) {
                planes_.read(++z_, 1, plane_.data());
                at_ = 0;
            }
            const std::size_t k = std::min(n, plane_.size() - at_);
            std::memcpy(dst, plane_.data() + at_, k);
            dst += k;
            at_ += k;
            n -= k;
        }
    }

private:
    VolumePlanes& planes_;
    std::vector<std::byte> plane_;
    int64_t z_ = -1;
    std::size_t at_ = 0;
};

}  // namespace

uint64_t write_samples(AtomicFile& out, const Volume& volume, Endian endian, Compression compression,
                       bool gzip_wrapper) {
    auto planes = planes_of(volume);
    return write_samples(out, *planes, endian, compression, gzip_wrapper);
}

uint64_t write_samples(AtomicFile& out, VolumePlanes& planes, Endian endian, Compression compression,
                       bool gzip_wrapper) {
    const std::size_t width = value_size(planes.header().type);
    const bool swap = endian != host_endian() && width > 1;
    PlaneBytes src(planes);
    const uint64_t total = src.total();
    const std::size_t chunk = kIoChunk - kIoChunk % width;
    std::vector<std::byte> buf(std::size_t(std::min<uint64_t>(chunk, total)));
    const uint64_t start = out.size();

    if (compression == Compression::None) {
        for (uint64_t done = 0; done < total;) {
            std::size_t n = static_cast<std::size_t>(std::min<uint64_t>(chunk, total - done));
            src.next(buf.data(), n);
            if (swap) swap_bytes(buf.data(), n, width);
            out.write(buf.data(), n);
            done += n;
        }
        return out.size() - start;
    }

    z_stream zs{};
    if (deflateInit2(&zs, 6, Z_DEFLATED, gzip_wrapper ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
        throw Error(ErrorCode::IoError, "cannot initialise zlib for '" + out.target() + "'");
    struct Guard {
        z_stream* z;
        ~Guard() { deflateEnd(z); }
    } guard{&zs};
    std::vector<unsigned char> zout(kZChunk);
    uint64_t done = 0;
    int flush = Z_NO_FLUSH;
    do {
        if (zs.avail_in == 0 && flush != Z_FINISH) {
            std::size_t n = static_cast<std::size_t>(std::min<uint64_t>(chunk, total - done));
            src.next(buf.data(), n);
            if (swap) swap_bytes(buf.data(), n, width);
            done += n;
            zs.next_in = reinterpret_cast<Bytef*>(buf.data());
            zs.avail_in = static_cast<uInt>(n);
            if (done == total) flush = Z_FINISH;
        }
        zs.next_out = zout.data();
        zs.avail_out = static_cast<uInt>(zout.size());
        int rc = deflate(&zs, flush);
        if (rc == Z_STREAM_ERROR) throw Error(ErrorCode::IoError, "zlib failed for '" + out.target() + "'");
        out.write(zout.data(), zout.size() - zs.avail_out);
        if (rc == Z_STREAM_END) break;
    } while (true);
    return out.size() - start;
}

std::string trim(std::string_view s) {
    std::size_t b = 0, e = s.size();
    while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
    while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
    return std::string(s.substr(b, e - b));
}

std::string to_lower(std::string_view s) {
    std::string r(s);
    for (auto& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return r;
}

std::vector<std::string> split_ws(std::string_view s) {
    std::vector<std::string> out;
    std::size_t i = 0;
    while (i < s.size()) {
        while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
        std::size_t b = i;
        while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
        if (i > b) out.emplace_back(s.substr(b, i - b));
    }
    return out;
}

double parse_double(const std::string& s, const std::string& what) {
    std::string l = to_lower(s);
    if (l == "nan") return std::nan("");
    if (l == "inf" || l == "+inf") return INFINITY;
    if (l == "-inf") return -INFINITY;
    double v = 0;
    const char* b = s.data();
    if (!s.empty() && s[0] == '+') ++b;
    auto [p, ec] = std::from_chars(b, s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size())
        throw Error(ErrorCode::CorruptData, what + ": '" + s + "' is not a number");
    return v;
}

int64_t parse_int(const std::string& s, const std::string& what) {
    int64_t v = 0;
    const char* b = s.data();
    if (!s.empty() && s[0] == '+') ++b;
    auto [p, ec] = std::from_chars(b, s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size())
        throw Error(ErrorCode::CorruptData, what + ": '" + s + "' is not an integer");
    return v;
}

std::string format_double(double v) {
    char buf[64];
    auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
    (void)ec;
    return std::string(buf, p);
}

std::string resolve_beside(const std::string& header_path, const std::string& name) {
    std::filesystem::path n(name);
    if (n.is_absolute()) return name;
    return (std::filesystem::path(header_path).parent_path() / n).string();
}

std::string resolve_data_file(const std::string& header_path, const std::string& name, bool allow_external,
                              const std::string& what) {
    namespace fs = std::filesystem;
    const std::string resolved = resolve_beside(header_path, name);
    // Checked as each name is resolved, so a pattern naming a million missing
    // files fails at the first instead of listing them all; FIFOs and devices
    // would block or never end (require_regular_file names the kind).
    auto require_regular = [&] {
        require_regular_file(resolved, "data file of " + what);
        return resolved;
    };
    if (allow_external) return require_regular();
    std::error_code ec;
    fs::path parent = fs::path(header_path).parent_path();
    if (parent.empty()) parent = ".";
    const fs::path dir = fs::absolute(parent, ec).lexically_normal();
    const fs::path file = fs::absolute(fs::path(resolved), ec).lexically_normal();
    const fs::path rel = file.lexically_relative(dir);
    const bool inside = !ec && !rel.empty() && *rel.begin() != ".." && !rel.is_absolute();
    if (!inside)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": the header names the data file '" + name + "', which is outside the header's folder; "
                           "pass --allow-external-data to read it");
    // The same after symbolic links: a link inside the folder may point anywhere
    // (/etc/shadow). Both sides resolved, so a folder reached through a link is fine.
    std::error_code real_ec;
    const fs::path real_dir = fs::canonical(dir, real_ec);
    const fs::path real_file = real_ec ? fs::path() : fs::weakly_canonical(file, real_ec);
    if (!real_ec) {
        const fs::path real_rel = real_file.lexically_relative(real_dir);
        if (real_rel.empty() || *real_rel.begin() == ".." || real_rel.is_absolute())
            throw Error(ErrorCode::UnsupportedFeature,
                        what + ": the data file '" + name + "' is a symbolic link to '" + real_file.string() +
                            "', outside the header's folder; pass --allow-external-data to read it");
    }
    return require_regular();
}

int64_t pattern_file_count(int64_t lo, int64_t hi, int64_t step, int64_t max_files, const std::string& what,
                           const std::string& field) {
    // In 128 bits: hi - lo and the division cannot overflow (INT64_MIN / -1 traps).
    const __int128 span = static_cast<__int128>(hi) - lo;
    if (step == 0 || (span != 0 && ((span < 0) != (step < 0))))
        throw Error(ErrorCode::CorruptData, what + ": " + field + " range " + std::to_string(lo) + " " +
                                                std::to_string(hi) + " " + std::to_string(step) +
                                                " is empty or endless");
    const __int128 n = span / step + 1;
    if (n > max_files)
        throw Error(ErrorCode::TooLarge, what + ": " + field + " pattern names more than " +
                                             std::to_string(max_files) + " files (" + std::to_string(lo) + " to " +
                                             std::to_string(hi) + " step " + std::to_string(step) + ")");
    return static_cast<int64_t>(n);
}

void check_geometry(const Vec3& spacing, const Vec3& origin, const std::string& what) {
    for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(spacing[a]) || !(spacing[a] > 0))
            throw Error(ErrorCode::CorruptData, what + ": spacing " + format_double(spacing[a]) + " on axis " +
                                                    std::to_string(a) + " is not a finite positive number");
        if (!std::isfinite(origin[a]))
            throw Error(ErrorCode::CorruptData, what + ": origin " + format_double(origin[a]) + " on axis " +
                                                    std::to_string(a) + " is not a finite number");
    }
}

std::string format_file_pattern(const std::string& pattern, int64_t n, const std::string& what) {
    // Exactly one conversion: %[flags][width]d (also i, u, x, X, o); "%%" is a literal %.
    // A NUL byte would end the printf format early (and std::strchr finds the
    // terminator of its set, so it would pass as a flag): no file name has one.
    if (pattern.find('\0') != std::string::npos)
        throw Error(ErrorCode::CorruptData, what + ": data file pattern contains a NUL byte");
    auto one_of = [](char c, std::string_view set) { return set.find(c) != std::string_view::npos; };
    std::string out;
    int conversions = 0;
    for (std::size_t i = 0; i < pattern.size(); ++i) {
        char c = pattern[i];
        if (c != '%') {
            out += c;
            continue;
        }
        if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
            out += '%';
            ++i;
            continue;
        }
        std::size_t j = i + 1;
        while (j < pattern.size() && one_of(pattern[j], "-+ #0123456789")) ++j;
        if (j >= pattern.size() || !one_of(pattern[j], "diuxXo") || j - i > 8)
            throw Error(ErrorCode::CorruptData,
                        what + ": data file pattern '" + pattern + "' needs one integer conversion such as %d");
        std::string spec = pattern.substr(i, j - i) + "ll" + pattern[j];
        char buf[64];
        std::snprintf(buf, sizeof buf, spec.c_str(), static_cast<long long>(n));
        out += buf;
        ++conversions;
        i = j;
    }
    if (conversions != 1)
        throw Error(ErrorCode::CorruptData,
                    what + ": data file pattern '" + pattern + "' needs exactly one integer conversion such as %d");
    return out;
}

}  // namespace tetlod::detail
