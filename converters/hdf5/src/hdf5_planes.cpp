// An HDF5 dataset read plane by plane by hyperslab: in this process, or in a
// persistent isolated child (open_planes_isolated) that keeps the file open and
// answers each plane request. See tetlod/converters/hdf5.hpp.
#include <filesystem>

#include "hdf5_dataset.hpp"
#include "hdf5_read_guard.hpp"
#include "tetlod/converters/hdf5.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_planes.hpp"
#include "tetlod/core/regular_file.hpp"

namespace tetlod {

using namespace hdf5_detail;

namespace {

// Memory a read needs besides the chunk cache and the transposition slab: the
// library's type-conversion buffer (1 MiB by default) and its bookkeeping.
constexpr uint64_t kReadOverheadBytes = uint64_t{8} << 20;

class Hdf5Planes final : public VolumePlanes {
  public:
    Hdf5Planes(const std::string& file, const std::string& dataset,
               const VolumeReadOptions& options, uint64_t file_size)
        : src_((silence_hdf5(),
                open_hdf5_source(file, dataset, options, file_size, /*for_planes=*/true))) {}

    const Volume& header() const override { return src_.header; }

    void read(int64_t z0, int64_t count, std::byte* dst) override {
        const Dims d = src_.header.dims;
        if (z0 < 0 || count < 0 || count > d.z || z0 > d.z - count)
            throw Error(ErrorCode::InvalidArgument, src_.what + ": planes " + std::to_string(z0) +
                                                        ".." + std::to_string(z0 + count - 1) +
                                                        " outside the volume");
        if (count > 0) read_hdf5_planes(src_, z0, count, dst, scratch_);
    }

    /// What reads need beyond the caller's buffer when they ask for at most
    /// `max_request_bytes` at a time.
    uint64_t working_bytes(uint64_t max_request_bytes) const {
        return src_.cache_bytes + (src_.xyz ? max_request_bytes : 0) + kReadOverheadBytes;
    }

  private:
    Hdf5Source src_;
    std::vector<std::byte> scratch_;
};

}  // namespace

std::unique_ptr<VolumePlanes> open_hdf5_planes(const std::string& file, const std::string& dataset,
                                               const VolumeReadOptions& options) {
    require_regular_file(file, "HDF5 file");
    std::error_code ec;
    const uint64_t file_size = std::filesystem::file_size(file, ec);
    if (ec) throw Error(ErrorCode::IoError, "cannot open '" + file + "': " + ec.message());
    hdf5_guard::check_hdf5_superblock(file, file_size);
    if (!options.isolation.enabled)
        return std::make_unique<Hdf5Planes>(file, dataset, options, file_size);
    // Opening parses the file's metadata under the whole read's limits; each
    // plane request then has its own deadline and a memory cap of what it needs.
    IsolatedTask task{"the HDF5 library", file, isolation_time_limit(options.isolation, file_size),
                      isolation_memory_limit(options.isolation, file_size)};
    return open_planes_isolated(task, options.isolation, [&] {
        auto planes = std::make_unique<Hdf5Planes>(file, dataset, options, file_size);
        const Volume& h = planes->header();
        const uint64_t plane = uint64_t(h.dims.x) * uint64_t(h.dims.y) * value_size(h.type);
        const uint64_t working = planes->working_bytes(std::max(plane, kIsolatedPieceBytes));
        return PlanesInChild{std::move(planes), working};
    });
}

}  // namespace tetlod
