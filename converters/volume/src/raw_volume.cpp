#include "tetlod/converters/raw_volume.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <exception>
#include <thread>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <vector>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/output_policy.hpp"
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

namespace {

/// What a raw file holds, checked against its size before anything is allocated.
struct RawLayout {
    Dims dims;
    ValueType type = ValueType::U8;
}; 

RawLayout raw_layout(const std::string& path, const VolumeReadOptions& options) {
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
    return RawLayout{dims, type};
}

void set_geometry(Volume& v, const std::string& path, const VolumeReadOptions& options) {
    if (options.spacing) v.spacing = *options.spacing;
    if (options.origin) v.origin = *options.origin;
    v.metadata["source_file"] = std::filesystem::path(path).filename().string();
}

/// Planes read by offset: a plane costs one pread, wherever it lies.
class RawPlanes final : public VolumePlanes {
public:
    RawPlanes(const std::string& path, uint64_t offset, Volume header, Endian endian)
        : path_(path), header_bytes_(offset), swap_(needs_swap(endian)), header_(std::move(header)) {
        header_.data = {};
        note_input_file(path);  // read while outputs are written: never one of them
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd_ < 0) throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + std::strerror(errno));
    }
    ~RawPlanes() override { ::close(fd_); }

    const Volume& header() const override { return header_; }

    void read(int64_t z0, int64_t count, std::byte* dst) override {
        const Dims& d = header_.dims;
        if (z0 < 0 || count < 0 || z0 + count > d.z)
            throw Error(ErrorCode::InvalidArgument, "'" + path_ + "': planes " + std::to_string(z0) + ".." +
                                                        std::to_string(z0 + count - 1) + " outside the volume");
        const std::size_t elem = value_size(header_.type);
        const uint64_t plane = uint64_t(d.x * d.y) * elem;
        uint64_t offset = header_bytes_ + uint64_t(z0) * plane;
        std::size_t left = std::size_t(uint64_t(count) * plane);
        std::byte* out = dst;
        while (left > 0) {
            const ssize_t got = ::pread(fd_, out, std::min<std::size_t>(left, kSlabBytes), off_t(offset));
            if (got < 0 && errno == EINTR) continue;
            if (got < 0) throw Error(ErrorCode::IoError, "cannot read '" + path_ + "': " + std::strerror(errno));
            if (got == 0)
                throw Error(ErrorCode::Truncated, "'" + path_ + "': file ended at byte " + std::to_string(offset) +
                                                      " while reading samples (was it changed while being read?)");
            out += got;
            offset += uint64_t(got);
            left -= std::size_t(got);
        }
        if (swap_) swap_bytes(dst, std::size_t(uint64_t(count) * plane), elem);
    }

private:
    std::string path_;
    uint64_t header_bytes_;
    bool swap_;
    Volume header_;
    int fd_ = -1;
};

}  // namespace

std::unique_ptr<VolumePlanes> open_raw_volume_planes(const std::string& path, const VolumeReadOptions& options) {
    const RawLayout layout = raw_layout(path, options);
    Volume header;
    header.dims = layout.dims;
    header.type = layout.type;
    set_geometry(header, path, options);
    return std::make_unique<RawPlanes>(path, options.header_bytes, std::move(header), options.endian);
}

std::unique_ptr<VolumePlanes> open_raw_planes_at(const std::string& path, uint64_t offset, Volume header,
                                                 Endian endian) {
    require_regular_file(path, "volume data");
    std::error_code ec;
    const uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + ec.message());
    validate_dims(header.dims, "'" + path + "'");
    const uint64_t payload = uint64_t(header.dims.count()) * value_size(header.type);
    if (offset > size || size - offset < payload)
        throw Error(ErrorCode::Truncated, "'" + path + "': " + std::to_string(payload) + " bytes of samples from byte " +
                                              std::to_string(offset) + " do not fit in its " + std::to_string(size) +
                                              " bytes");
    return std::make_unique<RawPlanes>(path, offset, std::move(header), endian);
}

Volume read_raw_volume(const std::string& path, const VolumeReadOptions& options) {
    const RawLayout layout = raw_layout(path, options);
    const Dims dims = layout.dims;
    const ValueType type = layout.type;

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

    set_geometry(v, path, options);
    return v;
}

void write_raw_volume(VolumePlanes& planes, const std::string& path, Endian endian) {
    const Volume& h = planes.header();
    const std::size_t elem = value_size(h.type);
    const std::size_t plane = std::size_t(h.dims.x * h.dims.y) * elem;
    // A few planes per write: bounded memory, few system calls. Two buffers of
    // half a slab each (the memory of one slab): the next slab is read (a
    // container decodes it) while a thread writes the previous one, so the
    // writes (copies into the page cache, ~2 ms a MB here) overlap the decode
    // instead of stopping it.
    const int64_t per = std::max<int64_t>(1, int64_t(kSlabBytes / 2 / std::max<std::size_t>(plane, 1)));
    const std::size_t cap = std::size_t(std::min(per, h.dims.z)) * plane;
    std::vector<std::byte> buf[2];
    AtomicFile out(path);
    std::thread writer;
    std::exception_ptr failed;
    // Joined on every way out (a thread destroyed joinable would terminate).
    struct Join {
        std::thread& t;
        ~Join() {
            if (t.joinable()) t.join();
        }
    } join{writer};
    auto wait = [&] {
        if (writer.joinable()) writer.join();
        if (failed) std::rethrow_exception(failed);
    };
    int k = 0;
    for (int64_t z = 0; z < h.dims.z; z += per, k ^= 1) {
        const int64_t n = std::min(per, h.dims.z - z);
        std::vector<std::byte>& b = buf[k];
        if (b.empty()) b.resize(cap);
        planes.read(z, n, b.data());
        if (needs_swap(endian)) swap_bytes(b.data(), std::size_t(n) * plane, elem);
        wait();  // the write of the other buffer; this one was written two slabs ago
        const std::size_t bytes = std::size_t(n) * plane;
        writer = std::thread([&out, &failed, data = b.data(), bytes] {
            try {
                out.write(data, bytes);
            } catch (...) {
                failed = std::current_exception();
            }
        });
    }
    wait();
    out.commit();
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
