#pragma once
// HT <-> .tlod sections (spec/tlod-format.md §6-§8).
//
// Field: points are coded cycle by cycle, coarse to fine. A point of cycle t
// (coordinates multiples of h = 2^t, not all of 2h) is predicted by the floor of
// the mean of its coarser neighbours c + sum_{i odd} (+-h) e_i that lie in the
// data box: the endpoints of the edge it bisects (class 2), the four corners of
// the face (class 1) or the eight corners of the cube (class 0) whose centre it
// is. Those neighbours are multiples of 2h, hence in coarser cycles, so every
// chunk depends only on chunks of coarser cycles. Values are integers in the
// "value domain" (floats: sign-magnitude bits mapped to ordered two's
// complement), residuals are taken modulo 2^W, zigzagged and split into byte
// planes before zstd: bit-exact for every value type.
//
// This header: the value domain, the chunk geometry (cycles, bricks) and the
// list of chunks in file order.

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

#include "ht_codec_entropy.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/models/detail/ht_geometry.hpp"
#include "tetlod/format/byte_io.hpp"

namespace tetlod::ht_detail {

using i128 = __int128;
constexpr uint8_t kPredictorCoarseMean = 1;
constexpr uint8_t kResidualZigzagPlanes = 1;
constexpr std::size_t kHtHeaderSize = 24;
constexpr uint8_t kPredictorNeighbours = 2;
constexpr uint8_t kResidualRangeCoder = 2;
/// Spec §7.5: a coded chunk holds at most this many points per stored byte.
constexpr uint64_t kMaxPointsPerByte = 8192;

// ---- value domain ----
template <class T> struct Dom {
    static constexpr int W = int(sizeof(T)) * 8;
    using U = std::conditional_t<sizeof(T) == 1, uint8_t,
              std::conditional_t<sizeof(T) == 2, uint16_t,
              std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
    using S = std::make_signed_t<U>;
    static int64_t get(T v) {
        if constexpr (std::is_floating_point_v<T>) {
            U b = std::bit_cast<U>(v);
            S s = static_cast<S>(b);
            if (s < 0) s = static_cast<S>(b ^ (std::numeric_limits<U>::max() >> 1));
            return s;
        } else {
            return static_cast<int64_t>(v);
        }
    }
    /// Value from its W-bit domain pattern.
    static T put(U bits) {
        if constexpr (std::is_floating_point_v<T>) {
            S s = static_cast<S>(bits);
            U b = s < 0 ? U(bits ^ (std::numeric_limits<U>::max() >> 1)) : bits;
            return std::bit_cast<T>(b);
        } else {
            return static_cast<T>(bits);
        }
    }
    static U zigzag(U r) {  // r: W-bit two's complement residual
        return U(U(r << 1) ^ U(-(r >> (W - 1))));
    }
    static U unzigzag(U z) { return U((z >> 1) ^ U(-(z & 1))); }
};

// ---- geometry of chunks ----
struct Geometry {
    int k = 0;
    int g = 0;
    std::array<int64_t, 3> box_max{};
    // Where the array a coder reads and writes lies: by default the whole field
    // on B (origin 0, stride 1, dims nx, ny). A chunk decoded on its own uses a
    // window instead: the lattice of spacing 2^shift from `origin`, which holds
    // every point its coders touch (window_for).
    int64_t nx = 0, ny = 0;  // array dims (x, y)
    std::array<int64_t, 3> origin{0, 0, 0};
    int shift = 0;

    int64_t side(int t) const { return int64_t{1} << (t + 1 + g); }
    std::array<int64_t, 3> bricks(int t) const {
        std::array<int64_t, 3> n{};
        for (int a = 0; a < 3; ++a) n[a] = std::max<int64_t>(1, (box_max[a] + side(t) - 1) / side(t));
        return n;
    }
    std::array<int64_t, 6> brick_box(int t, uint32_t b) const {
        auto n = bricks(t);
        int64_t bi[3] = {int64_t(b) % n[0], (int64_t(b) / n[0]) % n[1], int64_t(b) / (n[0] * n[1])};
        std::array<int64_t, 6> r{};
        for (int a = 0; a < 3; ++a) {
            r[a] = bi[a] * side(t);
            r[3 + a] = bi[a] == n[a] - 1 ? box_max[a] : (bi[a] + 1) * side(t) - 1;
        }
        return r;
    }
    int64_t index(int64_t x, int64_t y, int64_t z) const {
        return (((z - origin[2]) >> shift) * ny + ((y - origin[1]) >> shift)) * nx + ((x - origin[0]) >> shift);
    }
    /// index(p + (dx, dy, dz)) - index(p) for an offset on the array's lattice.
    int64_t index_delta(int64_t dx, int64_t dy, int64_t dz) const {
        return ((dz >> shift) * ny + (dy >> shift)) * nx + (dx >> shift);
    }

    /// Calls f(x0, x1, step, y, z) for the rows of the points of cycle t in the
    /// box, z outer: the points (x0 + i·step, y, z) with x <= x1 (x0 <= x1).
    template <class F> void for_each_row(int t, const std::array<int64_t, 6>& b, F&& f) const {
        const int64_t h = int64_t{1} << t;
        auto up = [&](int64_t v, int64_t m) { return (v + m - 1) / m * m; };
        if (t == k) {
            const int64_t L = h;
            for (int64_t z = up(b[2], L); z <= b[5]; z += L)
                for (int64_t y = up(b[1], L); y <= b[4]; y += L) {
                    const int64_t x0 = up(b[0], L);
                    if (x0 <= b[3]) f(x0, b[3], L, y, z);
                }
            return;
        }
        for (int64_t z = up(b[2], h); z <= b[5]; z += h) {
            const bool ze = (z & (2 * h - 1)) == 0;
            for (int64_t y = up(b[1], h); y <= b[4]; y += h) {
                const bool ye = (y & (2 * h - 1)) == 0;
                int64_t x0 = up(b[0], h);
                int64_t step = h;
                if (ze && ye) {  // y and z even: only the odd x are of cycle t
                    if ((x0 & (2 * h - 1)) == 0) x0 += h;
                    step = 2 * h;
                }
                if (x0 <= b[3]) f(x0, b[3], step, y, z);
            }
        }
    }
    /// Calls f(x, y, z) for the points of cycle t in the box, z outer, x inner.
    template <class F> void for_each_point(int t, const std::array<int64_t, 6>& b, F&& f) const {
        for_each_row(t, b, [&](int64_t x0, int64_t x1, int64_t step, int64_t y, int64_t z) {
            for (int64_t x = x0; x <= x1; x += step) f(x, y, z);
        });
    }
    uint64_t count_points(int t, const std::array<int64_t, 6>& b) const {
        // Closed form: multiples of h per axis minus the multiples of 2h (t < k).
        const int64_t h = int64_t{1} << t;
        auto cnt = [](int64_t lo, int64_t hi, int64_t m) -> int64_t {
            if (hi < lo) return 0;
            return hi / m - (lo + m - 1) / m + 1;
        };
        uint64_t all = 1, even = 1;
        for (int a = 0; a < 3; ++a) {
            all *= uint64_t(cnt(b[a], b[3 + a], h));
            even *= uint64_t(cnt(b[a], b[3 + a], 2 * h));
        }
        return t == k ? all : all - even;
    }

    /// Spec §8.2: quantized |f(c) - (f(A) + f(B)) / 2| over the spine A-B of the
    /// diamond centred at c (a lower bound of its error), 0 when A or B is outside B.
    template <class T> uint16_t spine_code(const T* v, int t, int64_t x, int64_t y, int64_t z, int m) const {
        const int64_t h = int64_t{1} << t;
        const int64_t c[3] = {x, y, z};
        int64_t a[3], b[3];
        for (int i = 0; i < 3; ++i) {
            if ((c[i] & h) != 0) {
                const int64_t sig = ((c[i] + h) & (4 * h - 1)) == 0 ? 1 : -1;
                a[i] = c[i] + sig * h;
                b[i] = c[i] - sig * h;
            } else {
                a[i] = b[i] = c[i];
            }
            if (a[i] < 0 || a[i] > box_max[i] || b[i] < 0 || b[i] > box_max[i]) return 0;
        }
        const double fa = static_cast<double>(v[index(a[0], a[1], a[2])]);
        const double fb = static_cast<double>(v[index(b[0], b[1], b[2])]);
        const double fc = static_cast<double>(v[index(x, y, z)]);
        const double lb = std::fabs(fc - 0.5 * (fa + fb));
        return quantize_error(static_cast<float>(lb), m);
    }

    /// floor(mean of the in-box coarser neighbours) in the value domain.
    template <class T> int64_t predict(const T* v, int t, int64_t x, int64_t y, int64_t z) const {
        if (t == k) return 0;
        const int64_t h = int64_t{1} << t;
        const int64_t c[3] = {x, y, z};
        int64_t lo[3], hi[3];
        int shift = 0;
        for (int a = 0; a < 3; ++a) {
            if ((c[a] & h) != 0) {  // odd multiple of h
                lo[a] = c[a] - h;
                if (c[a] + h <= box_max[a]) {
                    hi[a] = c[a] + h;
                    ++shift;
                } else {
                    hi[a] = lo[a];
                }
            } else {
                lo[a] = hi[a] = c[a];
            }
        }
        i128 sum = 0;
        for (int64_t zz = lo[2];; zz = hi[2]) {
            for (int64_t yy = lo[1];; yy = hi[1]) {
                sum += Dom<T>::get(v[index(lo[0], yy, zz)]);
                if (hi[0] != lo[0]) sum += Dom<T>::get(v[index(hi[0], yy, zz)]);
                if (yy == hi[1]) break;
            }
            if (zz == hi[2]) break;
        }
        return static_cast<int64_t>(sum >> shift);
    }
};

inline Geometry geometry_of(const HtDomain& d, int g) {
    Geometry G;
    G.k = d.k;
    G.g = g;
    for (int a = 0; a < 3; ++a) G.box_max[a] = d.box_max[a];
    G.nx = d.box_max[0] + 1;
    G.ny = d.box_max[1] + 1;
    return G;
}

/// The window a chunk of cycle t with box `b` is decoded in on its own: the
/// lattice of spacing h = 2^t over the box grown by h (clipped to B), where
/// every point its predictors and error bounds read lies (spec §6.3, §7.3,
/// §8.3). `count` receives the window's number of points.
inline Geometry window_for(const Geometry& G, int t, const std::array<int64_t, 6>& b, int64_t* count) {
    Geometry W = G;
    const int64_t h = int64_t{1} << t;
    W.shift = t;
    int64_t n[3];
    for (int a = 0; a < 3; ++a) {
        // b[a] is a multiple of the brick side (>= 2h), so lo stays on the lattice.
        const int64_t lo = std::max<int64_t>(0, b[a] - h);
        const int64_t hi = std::min<int64_t>(G.box_max[a], b[3 + a] + h);
        W.origin[a] = lo;
        n[a] = hi >= lo ? (hi - lo) / h + 1 : 0;
    }
    W.nx = n[0];
    W.ny = n[1];
    if (count) *count = n[0] * n[1] * n[2];
    return W;
}

inline std::vector<HtChunk> chunk_list(const Geometry& G) {
    std::vector<HtChunk> out;
    for (int t = G.k; t >= 0; --t) {
        auto n = G.bricks(t);
        const uint32_t nb = uint32_t(n[0] * n[1] * n[2]);
        for (uint32_t b = 0; b < nb; ++b) {
            HtChunk c;
            c.cycle = t;
            c.brick = b;
            c.box = G.brick_box(t, b);
            c.points = G.count_points(t, c.box);
            c.diamonds = t == G.k ? 0 : c.points;
            out.push_back(c);
        }
    }
    return out;
}

}  // namespace tetlod::ht_detail
