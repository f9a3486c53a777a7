// Closed-loop lossy quantization of an HT field (format 3.1, spec §5.1,
// informative): each sample is moved, within E, to its coder's prediction
// plus a multiple of the step, visiting the points in the coder's own order
// (cycle k first, each chunk in class order) so every prediction reads values
// already final. The encoder then codes residuals that are 0 wherever the
// prediction was within E (smooth regions) and multiples of the step
// elsewhere. The bound never depends on matching the coder: each sample is
// checked against the original as it is replaced.
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "ht_chunk_geometry.hpp"
#include "ht_field_chunk_coder.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/lossy_field.hpp"

namespace tetlod {

using namespace ht_detail;

namespace {

/// One point's replacement (a value type, as walk_field_chunk wants).
template <class T>
struct QuantizeStep {
    T* v = nullptr;
    double e = 0;
    int64_t s = 1;  // integers: the odd step 2*floor(E)+1

    void operator()(int, const Prediction& pr, int64_t idx, int64_t) {
        using D = Dom<T>;
        const T x = v[idx];
        if constexpr (std::is_floating_point_v<T>) {
            const T p = D::put(typename D::U(uint64_t(pr.p)));
            if (!std::isfinite(p)) return quantize_samples_one(idx);
            const double q = std::nearbyint((double(x) - double(p)) / (2 * e));
            const T c = q == 0 ? p : T(double(p) + q * 2 * e);
            // Kept only when the rounded distance is below E (then the exact one is at most E).
            if (c != x && !(std::fabs(double(c) - double(x)) < e)) return quantize_samples_one(idx);
            v[idx] = c;
        } else {
            const int64_t lo = int64_t(std::numeric_limits<T>::min()), hi = int64_t(std::numeric_limits<T>::max());
            const int64_t p = std::clamp<int64_t>(pr.p, lo, hi);
            const int64_t r = int64_t(x) - p, h = (s - 1) / 2;
            // Nearest multiple of s to r (floor division of r + h): |r - q*s| <= h <= E.
            int64_t q = (r + h) / s;
            if ((r + h) % s != 0 && r + h < 0) --q;
            v[idx] = T(std::clamp<int64_t>(p + q * s, lo, hi));  // clamping only moves towards x
        }
    }
    /// The per-sample quantizer where the prediction cannot serve.
    void quantize_samples_one(int64_t idx) {
        quantize_samples(value_type_of<T>(), reinterpret_cast<std::byte*>(v + idx), 1, e);
    }
};

}  // namespace

void quantize_predicted(Volume& volume, int brick_log2, double max_error) {
    if (!(max_error > 0) || !std::isfinite(max_error))
        throw Error(ErrorCode::InvalidArgument, "lossy max error must be finite and > 0");
    if (volume.dims.x < 2 || volume.dims.y < 2 || volume.dims.z < 2) {
        quantize_volume(volume, max_error);
        return;
    }
    const HtDomain d = HtDomain::for_dims(volume.dims, false);
    const Geometry G = geometry_of(d, brick_log2);
    const std::vector<HtChunk> chunks = chunk_list(G);
    dispatch_value_type(volume.type, [&](auto tag) {
        using T = decltype(tag);
        QuantizeStep<T> proto;
        proto.v = reinterpret_cast<T*>(volume.data.data());
        proto.e = max_error;
        if constexpr (!std::is_floating_point_v<T>) {
            const double f = std::floor(std::min(max_error, 1099511627776.0));
            proto.s = 2 * int64_t(f) + 1;
            if (proto.s == 1) return;  // E < 1: integers stay exact
        }
        // Chunks of one cycle read only coarser cycles and their own brick: in parallel.
        std::size_t i = 0;
        while (i < chunks.size()) {
            std::size_t e = i;
            while (e < chunks.size() && chunks[e].cycle == chunks[i].cycle) ++e;
            tbb::parallel_for(i, e, [&](std::size_t j) {
                const HtChunk& c = chunks[j];
                if (c.points == 0) return;
                thread_local std::vector<uint32_t> storage;
                ChunkLattice lat(c.cycle, c.box, storage);
                QuantizeStep<T> step = proto;
                walk_field_chunk(G, static_cast<const T*>(proto.v), c, lat, step);
            });
            i = e;
        }
    });
}

}  // namespace tetlod
