#include "tetlod/converters/raw_volume.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <vector>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/regular_file.hpp"

namespace tetlod {

namespace {

// Slab size for reading and writing: large enough to amortise system calls,
// small enough that writing a swapped copy never doubles the memory of a volume.
constexpr std::size_t kSlabBytes = std::size_t{8} << 20;

bool needs_swap(Endian e) {
    return (e == Endian::Big) != (std::endian::native == std::endian::big);
}

// Reverses the bytes of each element of `elem` bytes in place (elem in {2,4,8}).
void swap_bytes(std::byte* p, std::size_t bytes, std::size_t elem) {
    if (elem < 2) return;
    for (std::size_t i = 0; i + elem <= bytes; i += elem) std::reverse(p + i, p + i + elem);
}

std::optional<int64_t> parse_int(std::string_view s) {
    int64_t v = 0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
    return v;
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

}  // namespace

std::optional<RawNameInfo> parse_raw_volume_name(const std::string& path) {
    const std::string stem = std::filesystem::path(path).stem().string();
    // NAME may itself contain underscores: the last two tokens are dims and dtype.
    const auto last = stem.rfind('_');
    if (last == std::string::npos || last == 0) return std::nullopt;
    const auto prev = stem.rfind('_', last - 1);
    if (prev == std::string::npos) return std::nullopt;
    const std::string_view dims_token = std::string_view(stem).substr(prev + 1, last - prev - 1);
    const auto type = parse_value_type(std::string_view(stem).substr(last + 1));
    if (!type) return std::nullopt;

    int64_t d[3];
    std::size_t start = 0;
    for (int a = 0; a < 3; ++a) {
        const auto x = dims_token.find_first_of("xX", start);
        if ((a < 2) != (x != std::string_view::npos)) return std::nullopt;
        const auto len = (a < 2 ? x : dims_token.size()) - start;
        const auto v = parse_int(dims_token.substr(start, len));
        if (!v || *v < 1) return std::nullopt;
        d[a] = *v;
        start = start + len + 1;
    }
    return RawNameInfo{Dims{d[0], d[1], d[2]}, *type};
}

Volume read_raw_volume(const std::string& path, const VolumeReadOptions& options) {
    // A missing file is the likelier mistake than a missing --dims: report it first.
    require_regular_file(path, "raw volume");
    std::error_code ec;
    const auto actual = std::filesystem::file_size(path, ec);
    if (ec) throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + ec.message());
    const auto named = parse_raw_volume_name(path);
    if ((!options.dims || !options.type) && !named)
        throw Error(ErrorCode::InvalidArgument,
                    "'" + path +
                        "': raw volume needs its dims and type (--dims X,Y,Z --dtype T) "
                        "or a file name like NAME_XxYxZ_DTYPE.raw");
    const Dims dims = options.dims ? *options.dims : named->dims;
    const ValueType type = options.type ? *options.type : named->type;

    validate_dims(dims, "'" + path + "'");
    for (int a = 0; a < 3; ++a)
        if (dims[a] < 2)
            throw Error(ErrorCode::InvalidArgument,
                        "'" + path + "': dimension " + std::to_string(a) + " is " +
                            std::to_string(dims[a]) +
                            "; a tetrahedral mesh needs at least 2 samples along each axis");

    // validate_dims bounds count() by 2^34 and the type by 8 bytes: no overflow.
    const uint64_t payload = static_cast<uint64_t>(dims.count()) * value_size(type);
    if (options.header_bytes > UINT64_MAX - payload || actual != options.header_bytes + payload) {
        const auto dims_text =
            std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" + std::to_string(dims.z);
        throw Error(ErrorCode::SizeMismatch,
                    "'" + path + "': expected " + std::to_string(options.header_bytes + payload) +
                        " bytes (" + std::to_string(options.header_bytes) + " header + " +
                        dims_text + " " + value_type_name(type) + " samples of " +
                        std::to_string(value_size(type)) + " bytes) but the file has " +
                        std::to_string(actual) + " bytes");
    }

    std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
    if (!f) throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + std::strerror(errno));
    if (options.header_bytes > 0 &&
        std::fseek(f.get(), static_cast<long>(options.header_bytes), SEEK_SET) != 0)
        throw Error(ErrorCode::IoError, "cannot seek in '" + path + "': " + std::strerror(errno));

    Volume v = Volume::allocate(dims, type);
    const std::size_t elem = value_size(type);
    const bool swap = needs_swap(options.endian);
    // Slabs are a whole number of samples so each can be swapped on its own.
    const std::size_t slab = kSlabBytes - kSlabBytes % elem;
    for (std::size_t done = 0; done < v.data.size();) {
        const std::size_t n = std::min(slab, v.data.size() - done);
        if (std::fread(v.data.data() + done, 1, n, f.get()) != n)
            throw Error(ErrorCode::Truncated,
                        "'" + path + "': file ended after " +
                            std::to_string(options.header_bytes + done) +
                            " bytes while reading samples (was it changed while being read?)");
        if (swap) swap_bytes(v.data.data() + done, n, elem);
        done += n;
    }

    if (options.spacing) v.spacing = *options.spacing;
    if (options.origin) v.origin = *options.origin;
    v.metadata["source_file"] = std::filesystem::path(path).filename().string();
    return v;
}

void write_raw_volume(const Volume& volume, const std::string& path, Endian endian) {
    const std::size_t elem = value_size(volume.type);
    if (volume.data.size() != static_cast<std::size_t>(volume.count()) * elem)
        throw Error(ErrorCode::InvalidArgument,
                    "cannot write '" + path + "': volume holds " +
                        std::to_string(volume.data.size()) + " bytes, its dims and type need " +
                        std::to_string(static_cast<std::size_t>(volume.count()) * elem));
    AtomicFile out(path);
    if (!needs_swap(endian)) {
        out.write(volume.data.data(), volume.data.size());
    } else {
        // Swap through a bounded buffer rather than copying the whole volume.
        const std::size_t slab = kSlabBytes - kSlabBytes % elem;
        std::vector<std::byte> buf(std::min(slab, volume.data.size()));
        for (std::size_t done = 0; done < volume.data.size();) {
            const std::size_t n = std::min(slab, volume.data.size() - done);
            std::memcpy(buf.data(), volume.data.data() + done, n);
            swap_bytes(buf.data(), n, elem);
            out.write(buf.data(), n);
            done += n;
        }
    }
    out.commit();
}

}  // namespace tetlod
