// The original volume of an HT container, plane by plane (open_ht_planes).
#include <tbb/parallel_for.h>

#include <cstring>

#include "ht_chunk_cache.hpp"
#include "ht_chunk_decoder.hpp"

namespace tetlod {

using namespace ht_detail;

namespace {

/// Twice the coarser chunks a row of the finest bricks needs (the rows of
/// every cycle >= 1 it meets, decoded in their windows): the cache then
/// decodes each chunk once.
std::size_t working_set(const HtLayout& L, const Geometry& G) {
    std::size_t bytes = 0;
    const std::size_t per_point = value_size(L.metadata.type);
    for (int t = 1; t <= G.k; ++t) {
        const auto nb = G.bricks(t);
        const int64_t lattice = (int64_t{1} << (G.g + 1)) + 3;  // window points per axis, at most
        bytes += std::size_t(nb[0] * nb[1]) * std::size_t(lattice * lattice * lattice) * per_point;
    }
    return 2 * bytes + (std::size_t{16} << 20);
}

class HtContainerPlanes final : public VolumePlanes {
public:
    HtContainerPlanes(tlod::ContainerReader reader, HtLayout layout, std::size_t cache_bytes)
        : r_(std::move(reader)), L_(std::move(layout)), G_(geometry_of(L_.domain, L_.brick_log2)),
          cache_(r_, L_, cache_bytes ? cache_bytes : working_set(L_, G_), /*errors=*/false), sd_(L_.metadata.dims), vs_(value_size(L_.metadata.type)),
          side0_(G_.side(0)) {
        header_.dims = sd_;
        header_.type = L_.metadata.type;
        restore_metadata(header_, L_.metadata);
        first_.assign(std::size_t(G_.k) + 1, 0);
        for (std::size_t i = L_.chunks.size(); i-- > 0;) first_[std::size_t(L_.chunks[i].cycle)] = i;
    }

    const Volume& header() const override { return header_; }

    void read(int64_t z0, int64_t count, std::byte* dst) override {
        if (z0 < 0 || count < 0 || z0 + count > sd_.z)
            throw Error(ErrorCode::InvalidArgument, r_.name() + ": planes " + std::to_string(z0) + ".." +
                                                        std::to_string(z0 + count - 1) + " outside the volume");
        const std::size_t plane = std::size_t(sd_.x * sd_.y) * vs_;
        for (int64_t z = z0; z < z0 + count; ++z) {
            const int64_t row = z / side0_;
            if (row != row_) decode_row(row);
            std::memcpy(dst + std::size_t(z - z0) * plane, rows_.data() + std::size_t(z - row * side0_) * plane,
                        plane);
        }
    }

private:
    /// Planes row * side0 .. of the source volume: every cycle's points there.
    void decode_row(int64_t row) {
        row_ = -1;
        const int64_t zlo = row * side0_, zhi = std::min(sd_.z - 1, zlo + side0_ - 1);
        // Fresh zero pages, committed as chunks fill them: a hostile header's
        // claimed planes cost only what its chunks really decode.
        try {
            rows_ = ZeroedVector<std::byte>();
            rows_ = ZeroedVector<std::byte>(std::size_t(zhi - zlo + 1) * std::size_t(sd_.x * sd_.y) * vs_);
        } catch (const std::bad_alloc&) {
            throw Error(ErrorCode::TooLarge, r_.name() + ": not enough memory for a row of " +
                                                 std::to_string(zhi - zlo + 1) + " planes of " +
                                                 std::to_string(sd_.x) + "x" + std::to_string(sd_.y));
        }
        for (int t = G_.k; t >= 0; --t) {
            const auto nb = G_.bricks(t);
            const int64_t side = G_.side(t);
            const int64_t bz0 = std::min(zlo / side, nb[2] - 1), bz1 = std::min(zhi / side, nb[2] - 1);
            std::vector<std::size_t> ids;
            for (int64_t bz = bz0; bz <= bz1; ++bz)
                for (int64_t by = 0; by < nb[1]; ++by)
                    for (int64_t bx = 0; bx < nb[0]; ++bx) {
                        const std::size_t id = first_[std::size_t(t)] + std::size_t((bz * nb[1] + by) * nb[0] + bx);
                        const auto& b = L_.chunks[id].box;
                        if (b[0] < sd_.x && b[1] < sd_.y) ids.push_back(id);  // padding beyond the data: skipped
                    }
            // The finest cycle is decoded once per row, in parallel and not
            // kept; coarser chunks span several rows and stay cached.
            tbb::parallel_for(std::size_t(0), ids.size(), [&](std::size_t i) {
                const std::size_t id = ids[i];
                const auto chunk = t == 0 ? cache_.decode_uncached(id, false) : cache_.get(id);
                const HtChunk& c = L_.chunks[id];
                std::array<int64_t, 6> box = c.box;
                box[2] = std::max(box[2], zlo);
                box[5] = std::min(box[5], zhi);
                box[3] = std::min(box[3], sd_.x - 1);
                box[4] = std::min(box[4], sd_.y - 1);
                if (box[2] > box[5]) return;
                copy_points(*chunk, t, box, zlo);
            });
        }
        row_ = row;
    }

    void copy_points(const DecodedChunk& chunk, int t, const std::array<int64_t, 6>& box, int64_t zlo) {
        dispatch_value_type(header_.type, [&](auto tag) {
            using T = decltype(tag);
            const T* src = reinterpret_cast<const T*>(chunk.field.data());
            T* dst = reinterpret_cast<T*>(rows_.data());
            const Geometry& W = chunk.window;
            // By rows: the indices are worked out once per row, and the rows
            // of cycle 0 with y or z odd (3/4 of its points) are contiguous in
            // both arrays.
            G_.for_each_row(t, box, [&](int64_t x0, int64_t x1, int64_t step, int64_t y, int64_t z) {
                T* d = dst + ((z - zlo) * sd_.y + y) * sd_.x;
                const T* s = src + W.index(x0, y, z);
                const int64_t ds = W.index_delta(step, 0, 0);
                if (step == 1 && ds == 1) {
                    std::memcpy(d + x0, s, std::size_t(x1 - x0 + 1) * sizeof(T));
                    return;
                }
                for (int64_t x = x0; x <= x1; x += step, s += ds) d[x] = *s;
            });
        });
    }

    tlod::ContainerReader r_;
    HtLayout L_;
    Geometry G_;
    HtChunkCache cache_;
    Dims sd_;
    std::size_t vs_;
    int64_t side0_;
    Volume header_;
    std::vector<std::size_t> first_;
    int64_t row_ = -1;
    ZeroedVector<std::byte> rows_;
};

}  // namespace

Expected<std::unique_ptr<VolumePlanes>> open_ht_planes(tlod::ContainerReader reader, std::size_t cache_bytes) {
    auto layout = read_ht_layout(reader);
    if (!layout) return layout.failure();
    return capture([&]() -> std::unique_ptr<VolumePlanes> {
        return std::make_unique<HtContainerPlanes>(std::move(reader), std::move(*layout), cache_bytes);
    });
}

Expected<std::unique_ptr<VolumePlanes>> open_ht_planes(const std::string& path, std::size_t cache_bytes) {
    auto r = tlod::ContainerReader::open(path);
    if (!r) return r.failure();
    return open_ht_planes(std::move(*r), cache_bytes);
}

}  // namespace tetlod
