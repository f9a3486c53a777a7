// open_planes_isolated: VolumePlanes over an IsolatedServer. See isolated_planes.hpp.
#include "tetlod/core/isolated_planes.hpp"

#include <algorithm>
#include <vector>

#include "isolated_child.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_server.hpp"
#include "tetlod/core/isolated_volume.hpp"

namespace tetlod {

namespace {

struct Request {
    int64_t z0 = 0, count = 0;
};

uint64_t plane_bytes(const Volume& h) {
    return uint64_t(h.dims.x) * uint64_t(h.dims.y) * value_size(h.type);
}

int64_t planes_per_piece(const Volume& h) {
    return std::max<int64_t>(1,
                             int64_t(kIsolatedPieceBytes / std::max<uint64_t>(1, plane_bytes(h))));
}

void check_range(const Volume& h, int64_t z0, int64_t count, const std::string& file) {
    if (z0 < 0 || count < 0 || count > h.dims.z || z0 > h.dims.z - count)
        throw Error(ErrorCode::InvalidArgument, "'" + file + "': planes " + std::to_string(z0) +
                                                    ".." + std::to_string(z0 + count - 1) +
                                                    " outside the volume");
}

// The child's side: open, send the header, answer requests until the parent goes.
void serve(const IsolatedTask& task, const IsolationOptions& options,
           const std::function<PlanesInChild()>& open, IsolatedRequests& requests,
           IsolatedWriter& replies) {
    PlanesInChild src = open();
    if (!src.planes)
        throw Error(ErrorCode::IoError, "'" + task.file + "': nothing to read planes from");
    const Volume& h = src.planes->header();
    send_volume_header(replies, h);
    const int64_t per = planes_per_piece(h);
    const uint64_t plane = plane_bytes(h);
    std::vector<std::byte> piece(std::size_t(std::min(per, h.dims.z) * int64_t(plane)));
    // Opening is done: from here on a read may take what a request needs.
    isolated_detail::limit_data_beyond_current(options.memory_limit_bytes > 0
                                                   ? options.memory_limit_bytes
                                                   : options.memory_base_bytes + src.working_bytes);
    Request q;
    while (requests.next(&q, sizeof q)) {
        check_range(h, q.z0, q.count, task.file);
        for (int64_t z = q.z0; z < q.z0 + q.count; z += per) {
            const int64_t n = std::min(per, q.z0 + q.count - z);
            src.planes->read(z, n, piece.data());
            replies.write(piece.data(), std::size_t(n) * plane);
        }
    }
}

class IsolatedPlanes final : public VolumePlanes {
  public:
    IsolatedPlanes(const IsolatedTask& task, const IsolationOptions& options,
                   const std::function<PlanesInChild()>& open)
        : options_(options), server_(task, [&](IsolatedRequests& rq, IsolatedWriter& w) {
              serve(task, options, open, rq, w);
          }) {
        server_.call(nullptr, 0, task.time_limit_seconds, [&](IsolatedReader& r) {
            header_ = receive_volume_header(r, server_.task());
        });
        plane_ = plane_bytes(header_);
    }

    const Volume& header() const override { return header_; }

    void read(int64_t z0, int64_t count, std::byte* dst) override {
        check_range(header_, z0, count, server_.task().file);
        if (count == 0) return;
        const Request q{z0, count};
        const uint64_t bytes = uint64_t(count) * plane_;
        server_.call(&q, sizeof q, isolation_time_limit(options_, bytes),
                     [&](IsolatedReader& r) { r.read(dst, std::size_t(bytes)); });
    }

  private:
    IsolationOptions options_;
    IsolatedServer server_;
    Volume header_;
    uint64_t plane_ = 0;
};

}  // namespace

std::unique_ptr<VolumePlanes> open_planes_isolated(const IsolatedTask& task,
                                                   const IsolationOptions& options,
                                                   const std::function<PlanesInChild()>& open) {
    return std::make_unique<IsolatedPlanes>(task, options, open);
}

}  // namespace tetlod
