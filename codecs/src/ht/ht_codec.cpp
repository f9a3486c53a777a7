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
#include "tetlod/codecs/ht/ht_codec.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <span>
#include <type_traits>

#include "ht_codec_entropy.hpp"
#include "tetlod/models/detail/ht_geometry.hpp"
#include "tetlod/format/byte_io.hpp"

namespace tetlod {

namespace {

using i128 = __int128;
constexpr uint8_t kPredictorCoarseMean = 1;
constexpr uint8_t kResidualZigzagPlanes = 1;
constexpr std::size_t kHtHeaderSize = 24;

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
    int64_t nx = 0, ny = 0;  // field dims (x, y)

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
    int64_t index(int64_t x, int64_t y, int64_t z) const { return (z * ny + y) * nx + x; }

    /// Calls f(x, y, z) for the points of cycle t in the box, z outer, x inner.
    template <class F> void for_each_point(int t, const std::array<int64_t, 6>& b, F&& f) const {
        const int64_t h = int64_t{1} << t;
        auto up = [&](int64_t v, int64_t m) { return (v + m - 1) / m * m; };
        if (t == k) {
            const int64_t L = h;
            for (int64_t z = up(b[2], L); z <= b[5]; z += L)
                for (int64_t y = up(b[1], L); y <= b[4]; y += L)
                    for (int64_t x = up(b[0], L); x <= b[3]; x += L) f(x, y, z);
            return;
        }
        for (int64_t z = up(b[2], h); z <= b[5]; z += h) {
            const bool ze = (z & (2 * h - 1)) == 0;
            for (int64_t y = up(b[1], h); y <= b[4]; y += h) {
                const bool ye = (y & (2 * h - 1)) == 0;
                const int64_t x0 = up(b[0], h);
                if (ze && ye) {
                    int64_t x = (x0 & (2 * h - 1)) == 0 ? x0 + h : x0;
                    for (; x <= b[3]; x += 2 * h) f(x, y, z);
                } else {
                    for (int64_t x = x0; x <= b[3]; x += h) f(x, y, z);
                }
            }
        }
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

Geometry geometry_of(const HtDomain& d, int g) {
    Geometry G;
    G.k = d.k;
    G.g = g;
    for (int a = 0; a < 3; ++a) G.box_max[a] = d.box_max[a];
    G.nx = d.box_max[0] + 1;
    G.ny = d.box_max[1] + 1;
    return G;
}

std::vector<HtChunk> chunk_list(const Geometry& G) {
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

template <class T>
std::vector<std::byte> encode_field_chunk(const Geometry& G, const T* v, const HtChunk& c) {
    using D = Dom<T>;
    constexpr int B = int(sizeof(T));
    const std::size_t n = c.points;
    std::vector<std::byte> raw(n * B);
    std::size_t i = 0;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        const int64_t p = G.predict(v, c.cycle, x, y, z);
        const typename D::U r = typename D::U(uint64_t(D::get(v[G.index(x, y, z)])) - uint64_t(p));
        const typename D::U zz = D::zigzag(r);
        for (int b = 0; b < B; ++b) raw[b * n + i] = std::byte(uint8_t(uint64_t(zz) >> (8 * b)));
        ++i;
    });
    return raw;
}

template <class T>
void decode_field_chunk(const Geometry& G, T* v, const HtChunk& c, const std::byte* raw) {
    using D = Dom<T>;
    constexpr int B = int(sizeof(T));
    const std::size_t n = c.points;
    std::size_t i = 0;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        uint64_t zz = 0;
        for (int b = 0; b < B; ++b) zz |= uint64_t(std::to_integer<uint8_t>(raw[b * n + i])) << (8 * b);
        const typename D::U r = D::unzigzag(typename D::U(zz));
        const int64_t p = G.predict(v, c.cycle, x, y, z);
        v[G.index(x, y, z)] = D::put(typename D::U(uint64_t(p) + uint64_t(r)));
        ++i;
    });
}

template <class T>
std::vector<std::byte> encode_error_chunk(const Geometry& G, const T* v, const std::vector<float>& e,
                                          const HtChunk& c, int m) {
    const std::size_t n = c.diamonds;
    std::vector<std::byte> raw(n * 2);
    if (n == 0) return raw;
    std::size_t i = 0;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        const uint16_t q = uint16_t(quantize_error(e[G.index(x, y, z)], m) -
                                    G.spine_code(v, c.cycle, x, y, z, m));
        raw[i] = std::byte(uint8_t(q));
        raw[n + i] = std::byte(uint8_t(q >> 8));
        ++i;
    });
    return raw;
}

/// False when a code is out of range.
template <class T>
bool decode_error_chunk(const Geometry& G, const T* v, ZeroedVector<float>& e, const HtChunk& c, int m,
                        const std::byte* raw) {
    const std::size_t n = c.diamonds;
    if (n == 0) return true;
    std::size_t i = 0;
    bool ok = true;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        const uint32_t d = std::to_integer<uint8_t>(raw[i]) | (uint32_t(std::to_integer<uint8_t>(raw[n + i])) << 8);
        const uint32_t q = (d + G.spine_code(v, c.cycle, x, y, z, m)) & 0xFFFFu;
        if (q > max_error_code(m)) ok = false;
        e[G.index(x, y, z)] = ok ? dequantize_error(uint16_t(q), m) : std::numeric_limits<float>::infinity();
        ++i;
    });
    return ok;
}

// ---- residual coding 2 (spec §7.3-§7.5, §8.3): class-ordered chunks, adaptive range coder ----

constexpr uint8_t kPredictorNeighbours = 2;
constexpr uint8_t kResidualRangeCoder = 2;
/// Spec §7.5: a coded chunk holds at most this many points per stored byte.
constexpr uint64_t kMaxPointsPerByte = 8192;

/// Activity bucket of spec §7.5: bit length, compressed above 8.
inline int activity_bucket(uint64_t a) {
    const int bl = rc::bit_length(a);
    return bl <= 8 ? bl : std::min(15, 8 + (bl - 6) / 3);
}

/// Lattice of a chunk's box at spacing h: per point a saturated magnitude + 1
/// (0 = not coded yet in this chunk), for the neighbour contexts. The lattice
/// carries a border of 2 cells below and 1 above on every axis that is never
/// set, so the neighbour lookups of spec §7.6 need no bounds checks.
struct ChunkLattice {
    int t = 0;
    int64_t x0 = 0, y0 = 0, z0 = 0;
    int64_t px = 0, pxy = 0;  // strides of the padded lattice
    std::vector<uint32_t>& mag;
    ChunkLattice(int cycle, const std::array<int64_t, 6>& b, std::vector<uint32_t>& storage)
        : t(cycle), mag(storage) {
        const int64_t h = int64_t{1} << t;
        auto up = [&](int64_t v) { return (v + h - 1) / h * h; };
        x0 = up(b[0]);
        y0 = up(b[1]);
        z0 = up(b[2]);
        const int64_t nx = b[3] >= x0 ? (b[3] - x0) / h + 1 : 0;
        const int64_t ny = b[4] >= y0 ? (b[4] - y0) / h + 1 : 0;
        const int64_t nz = b[5] >= z0 ? (b[5] - z0) / h + 1 : 0;
        px = nx + 3;
        pxy = px * (ny + 3);
        mag.assign(std::size_t(pxy * (nz + 3)), 0);
    }
    /// Slot of a point of the chunk (on the lattice, inside the box).
    int64_t slot(int64_t x, int64_t y, int64_t z) const {
        return (((z - z0) >> t) + 2) * pxy + (((y - y0) >> t) + 2) * px + ((x - x0) >> t) + 2;
    }
    void set(int64_t s, uint64_t m) { mag[std::size_t(s)] = uint32_t(std::min<uint64_t>(m, 0xFFFFFFFEu) + 1); }
    /// Spec §7.6: mean magnitude of the already coded lattice neighbours among
    /// (x±h), (y±h), (z±h), (x−2h), (y−2h), (z−2h) (integer division; 0 if none).
    uint64_t neighbour_mean(int64_t s) const {
        const uint32_t* q = mag.data() + s;
        const uint32_t v[9] = {q[-1], q[1], q[-px], q[px], q[-pxy], q[pxy], q[-2], q[-2 * px], q[-2 * pxy]};
        uint64_t sum = 0, n = 0;
        for (uint32_t w : v) {
            sum += w ? w - 1 : 0;
            n += w != 0;
        }
        return n ? sum / n : 0;
    }
};

/// Offsets of the 27 points c + h·(ox, oy, oz), o in {-1, 0, 1}^3, coded as
/// (ox+1) + 3(oy+1) + 9(oz+1).
constexpr int nb27(int ox, int oy, int oz) { return (ox + 1) + 3 * (oy + 1) + 9 * (oz + 1); }

/// Closed form of the edge scan of spec §8.3 for a diamond whose tets lie in the
/// chunk's box: the distinct edges (a, b) of its tets with their midpoint m on
/// the h-lattice, as 27-neighbour indices. The set depends only on the sign
/// pattern sig of §2 (0 on the even axes), which also fixes the class.
struct DiamondEdges {
    uint8_t n = 0;
    uint8_t a[48], b[48], m[48];
};
struct DiamondEdgeTable {
    DiamondEdges by_sig[27];
    DiamondEdgeTable() {
        static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
        for (int code = 0; code < 27; ++code) {
            const int sig[3] = {code % 3 - 1, code / 3 % 3 - 1, code / 9 - 1};
            if (sig[0] == 0 && sig[1] == 0 && sig[2] == 0) continue;
            // A representative centre of cycle 0 in [0, 16]^3: an odd axis with
            // sig = +1 is 3 ((3 + 1) mod 4 = 0), with sig = -1 is 1; an even axis is 2.
            ht::Pt c;
            for (int a = 0; a < 3; ++a) c[a] = sig[a] == 0 ? 2 : (sig[a] > 0 ? 3 : 1);
            ht::Tet tets[8];
            const int nt = ht::diamond_tets(c, ht::classify_centre(c, 4), 16, tets);
            DiamondEdges& E = by_sig[code];
            for (int i = 0; i < nt; ++i)
                for (const auto& e : kEdges) {
                    int oa[3], ob[3];
                    bool lattice = true;
                    for (int q = 0; q < 3; ++q) {
                        oa[q] = tets[i][e[0]][q] - c[q];
                        ob[q] = tets[i][e[1]][q] - c[q];
                        lattice = lattice && ((oa[q] + ob[q]) & 1) == 0;
                    }
                    if (!lattice) continue;
                    int ia = nb27(oa[0], oa[1], oa[2]), ib = nb27(ob[0], ob[1], ob[2]);
                    if (ia > ib) std::swap(ia, ib);
                    bool seen = false;
                    for (int j = 0; j < E.n; ++j) seen = seen || (E.a[j] == ia && E.b[j] == ib);
                    if (seen) continue;
                    E.a[E.n] = uint8_t(ia);
                    E.b[E.n] = uint8_t(ib);
                    E.m[E.n] = uint8_t(nb27((oa[0] + ob[0]) / 2, (oa[1] + ob[1]) / 2, (oa[2] + ob[2]) / 2));
                    ++E.n;
                }
        }
    }
};
const DiamondEdgeTable& diamond_edge_table() {
    static const DiamondEdgeTable table;
    return table;
}

/// Sign pattern code (index into DiamondEdgeTable) of a diamond centre of cycle t.
inline int sig_code(int64_t x, int64_t y, int64_t z, int64_t h) {
    auto sg = [h](int64_t v) { return (v & h) == 0 ? 1 : (((v + h) & (4 * h - 1)) == 0 ? 2 : 0); };
    return sg(x) + 3 * sg(y) + 9 * sg(z);
}

/// Per chunk: the linear field offsets of the 27 neighbours at spacing h, and
/// the test for the chunk interior (c ± h inside the chunk's box, which lies in
/// B), where every point a predictor or the lattice bound reads is available.
struct ChunkFrame {
    int64_t h = 1;
    std::array<int64_t, 6> cb{};
    int64_t off[27]{};
    ChunkFrame(const Geometry& G, int t, const std::array<int64_t, 6>& box) : h(int64_t{1} << t), cb(box) {
        for (int oz = -1; oz <= 1; ++oz)
            for (int oy = -1; oy <= 1; ++oy)
                for (int ox = -1; ox <= 1; ++ox)
                    off[nb27(ox, oy, oz)] = ((oz * h) * G.ny + oy * h) * G.nx + ox * h;
    }
    bool interior(int64_t x, int64_t y, int64_t z) const {
        return x - h >= cb[0] && y - h >= cb[1] && z - h >= cb[2] && x + h <= cb[3] && y + h <= cb[4] &&
               z + h <= cb[5];
    }
};

/// Per odd-axis mask: the coarse neighbours (±h on every odd axis) and the
/// fine ones (±h on one even axis) of the neighbour predictor, as 27-indices.
struct PredictorStencils {
    uint8_t nc[8]{}, nf[8]{};
    uint8_t coarse[8][8]{}, fine[8][6]{};
    PredictorStencils() {
        for (int mask = 1; mask < 8; ++mask) {
            for (int s = 0; s < 8; ++s) {
                int o[3];
                bool ok = true;
                for (int a = 0; a < 3; ++a) {
                    const int bit = (s >> a) & 1;
                    if (mask & (1 << a)) o[a] = bit ? 1 : -1;
                    else if (bit) ok = false;
                    else o[a] = 0;
                }
                if (ok) coarse[mask][nc[mask]++] = uint8_t(nb27(o[0], o[1], o[2]));
            }
            for (int a = 0; a < 3; ++a) {
                if (mask & (1 << a)) continue;
                for (int sg = -1; sg <= 1; sg += 2) {
                    int o[3] = {0, 0, 0};
                    o[a] = sg;
                    fine[mask][nf[mask]++] = uint8_t(nb27(o[0], o[1], o[2]));
                }
            }
        }
    }
};
const PredictorStencils& predictor_stencils() {
    static const PredictorStencils table;
    return table;
}

/// Calls f(x, y, z, cls) for the chunk's points in coding order 2: class 0
/// (cube centres), class 1 (face centres), class 2 (edge midpoints), each z
/// outer, x inner; the corner cycle t = k is one pass with cls = 3.
template <class F>
void for_each_point_v2(const Geometry& G, int t, const std::array<int64_t, 6>& b, F&& f) {
    if (t == G.k) {
        G.for_each_point(t, b, [&](int64_t x, int64_t y, int64_t z) { f(x, y, z, 3); });
        return;
    }
    const int64_t h = int64_t{1} << t;
    auto up = [&](int64_t v) { return (v + h - 1) / h * h; };
    for (int cls = 0; cls < 3; ++cls) {
        const int want_odd = 3 - cls;
        for (int64_t z = up(b[2]); z <= b[5]; z += h) {
            const int oz = (z & h) != 0;
            for (int64_t y = up(b[1]); y <= b[4]; y += h) {
                const int oy = (y & h) != 0;
                const int64_t xs = up(b[0]);
                // x parity fixed by the class: odd needed iff want_odd - oz - oy == 1.
                const int need = want_odd - oz - oy;
                if (need < 0 || need > 1) continue;
                int64_t x = xs;
                if (((x & h) != 0) != (need == 1)) x += h;
                for (; x <= b[3]; x += 2 * h) f(x, y, z, cls);
            }
        }
    }
}

struct Prediction {
    int64_t p = 0;
    uint64_t spread = 0;
};

/// Spec §7.3 (Predictor = 2).
template <class T>
Prediction predict_v2(const Geometry& G, const T* v, int t, int cls, int64_t x, int64_t y, int64_t z,
                      const std::array<int64_t, 6>& cb) {
    Prediction r;
    if (cls == 3) return r;
    const int64_t h = int64_t{1} << t;
    const int64_t c[3] = {x, y, z};
    int64_t mn = std::numeric_limits<int64_t>::max(), mx = std::numeric_limits<int64_t>::min();
    auto val = [&](int64_t a, int64_t b2, int64_t d) {
        const int64_t w = Dom<T>::get(v[G.index(a, b2, d)]);
        mn = std::min(mn, w);
        mx = std::max(mx, w);
        return w;
    };
    auto in_chunk = [&](const int64_t q[3]) {
        for (int a = 0; a < 3; ++a)
            if (q[a] < cb[a] || q[a] > cb[3 + a]) return false;
        return true;
    };
    // Coarse neighbours (as predictor 1).
    int64_t lo[3], hi[3];
    int shift = 0;
    bool all_in = true;
    for (int a = 0; a < 3; ++a) {
        if ((c[a] & h) != 0) {
            lo[a] = c[a] - h;
            if (c[a] + h <= G.box_max[a]) {
                hi[a] = c[a] + h;
                ++shift;
            } else {
                hi[a] = lo[a];
                all_in = false;
            }
        } else {
            lo[a] = hi[a] = c[a];
        }
    }
    i128 coarse = 0;
    for (int64_t zz = lo[2];; zz = hi[2]) {
        for (int64_t yy = lo[1];; yy = hi[1]) {
            coarse += val(lo[0], yy, zz);
            if (hi[0] != lo[0]) coarse += val(hi[0], yy, zz);
            if (yy == hi[1]) break;
        }
        if (zz == hi[2]) break;
    }
    // Same-cycle neighbours at distance h along the even axes, when all are in the chunk.
    i128 fine = 0;
    bool fine_ok = all_in && cls > 0 ;
    for (int a = 0; a < 3 && fine_ok; ++a) {
        if ((c[a] & h) != 0) continue;
        for (int s = -1; s <= 1; s += 2) {
            int64_t q[3] = {c[0], c[1], c[2]};
            q[a] += s * h;
            if (!in_chunk(q)) {
                fine_ok = false;
                break;
            }
        }
    }
    if (fine_ok) {
        for (int a = 0; a < 3; ++a) {
            if ((c[a] & h) != 0) continue;
            for (int s = -1; s <= 1; s += 2) {
                int64_t q[3] = {c[0], c[1], c[2]};
                q[a] += s * h;
                fine += val(q[0], q[1], q[2]);
            }
        }
        if (cls == 1)  // 4 face corners + 2 cube centres: (sum4 + 2 sum2) / 8
            r.p = int64_t((coarse + 2 * fine) >> 3);
        else  // edge: 2 ends + 4 face centres: (2 (A + B) + sum4) / 8
            r.p = int64_t((2 * coarse + fine) >> 3);
    } else {
        r.p = int64_t(coarse >> shift);
    }
    r.spread = uint64_t(mx) - uint64_t(mn);
    return r;
}

/// Predictor 2 in the chunk interior (ChunkFrame::interior): every coarse
/// neighbour is in B and every fine one in the chunk, so the stencils are fixed.
/// Same result as predict_v2 there.
template <class T>
Prediction predict_interior(const T* v, int64_t idx, int mask, int cls, const ChunkFrame& F) {
    using Sum = std::conditional_t<(sizeof(T) < 8), int64_t, i128>;
    const PredictorStencils& P = predictor_stencils();
    const T* c = v + idx;
    int64_t w = Dom<T>::get(c[F.off[P.coarse[mask][0]]]);
    int64_t mn = w, mx = w;
    Sum coarse = w;
    for (int i = 1; i < P.nc[mask]; ++i) {
        w = Dom<T>::get(c[F.off[P.coarse[mask][i]]]);
        coarse += w;
        mn = std::min(mn, w);
        mx = std::max(mx, w);
    }
    Prediction r;
    if (cls == 0) {
        r.p = int64_t(coarse >> 3);
    } else {
        Sum fine = 0;
        for (int i = 0; i < P.nf[mask]; ++i) {
            w = Dom<T>::get(c[F.off[P.fine[mask][i]]]);
            fine += w;
            mn = std::min(mn, w);
            mx = std::max(mx, w);
        }
        r.p = cls == 1 ? int64_t((coarse + 2 * fine) >> 3) : int64_t((2 * coarse + fine) >> 3);
    }
    r.spread = uint64_t(mx) - uint64_t(mn);
    return r;
}

template <class T>
Prediction predict_point(const Geometry& G, const T* v, const ChunkFrame& F, int t, int cls, int64_t x,
                         int64_t y, int64_t z, int64_t idx) {
    if (cls < 3 && F.interior(x, y, z)) {
        const int64_t h = F.h;
        const int mask = ((x & h) ? 1 : 0) | ((y & h) ? 2 : 0) | ((z & h) ? 4 : 0);
        return predict_interior(v, idx, mask, cls, F);
    }
    return predict_v2(G, v, t, cls, x, y, z, F.cb);
}

struct FieldModels {
    rc::IntModel m[4][16];
};
struct ErrorModels {
    rc::Bit inf[4][2];  // class 3 (corners) never used: corners are not diamonds
    rc::IntModel m[4][2][6];
};

template <class T>
std::vector<std::byte> encode_field_chunk_v2(const Geometry& G, const T* v, const HtChunk& c) {
    using D = Dom<T>;
    constexpr int W = D::W;
    std::vector<std::byte> out;
    if (c.points == 0) return out;
    auto models = std::make_unique<FieldModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    rc::Encoder enc(out);
    for_each_point_v2(G, c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z, int cls) {
        const int64_t idx = G.index(x, y, z);
        const Prediction pr = predict_point(G, v, F, c.cycle, cls, x, y, z, idx);
        const int64_t s = lat.slot(x, y, z);
        const uint64_t act = pr.spread + 2 * lat.neighbour_mean(s);
        const auto r = typename D::S(typename D::U(uint64_t(D::get(v[idx])) - uint64_t(pr.p)));
        const bool neg = r < 0;
        const uint64_t mag = neg ? uint64_t(0) - uint64_t(int64_t(r)) : uint64_t(r);
        rc::encode_int(enc, models->m[cls][activity_bucket(act)], mag, neg, W);
        lat.set(s, mag);
    });
    enc.finish();
    return out;
}

/// False on a malformed stream.
template <class T>
bool decode_field_chunk_v2(const Geometry& G, T* v, const HtChunk& c, std::span<const std::byte> in) {
    using D = Dom<T>;
    constexpr int W = D::W;
    if (c.points == 0) return in.empty();
    auto models = std::make_unique<FieldModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    rc::Decoder dec(in.data(), in.size());
    for_each_point_v2(G, c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z, int cls) {
        if (dec.overrun()) return;  // a valid stream never reads past its end: stop early
        const int64_t idx = G.index(x, y, z);
        const Prediction pr = predict_point(G, v, F, c.cycle, cls, x, y, z, idx);
        const int64_t s = lat.slot(x, y, z);
        const uint64_t act = pr.spread + 2 * lat.neighbour_mean(s);
        uint64_t mag;
        bool neg;
        rc::decode_int(dec, models->m[cls][activity_bucket(act)], mag, neg, W);
        const typename D::U r = neg ? typename D::U(uint64_t(0) - mag) : typename D::U(mag);
        v[idx] = D::put(typename D::U(uint64_t(pr.p) + uint64_t(r)));
        lat.set(s, mag);
    });
    return !dec.bad_end();
}

/// Spec §8.3: may the diamond centred at c have a tet outside B (then it may be +inf)?
inline int touches_far_face(const Geometry& G, int t, int64_t x, int64_t y, int64_t z) {
    const int64_t h = int64_t{1} << t;
    return (x + h > G.box_max[0] || y + h > G.box_max[1] || z + h > G.box_max[2]) ? 1 : 0;
}

/// Spec §8.3: the lattice lower bound of a diamond's error. Over the tets of the
/// diamond with all four vertices in B, and over their edges (a, b) whose
/// midpoint p lies on the lattice of spacing h = 2^t, the largest
/// |f(p) - (f(a) + f(b)) / 2| (L_T(p) at an edge midpoint), counting only
/// points already decoded: coarser cycles, or cycle t inside the chunk's box.
/// At cycle 0 every grid point of the tets is such a midpoint or a vertex, so
/// the bound is the exact diamond error unless a point lies in another brick.
template <class T>
uint32_t lattice_bound_code(const Geometry& G, const T* v, int t, int64_t x, int64_t y, int64_t z,
                            const std::array<int64_t, 6>& cb, int m) {
    const ht::Pt c{int32_t(x), int32_t(y), int32_t(z)};
    const ht::DiamondInfo di = ht::classify_centre(c, G.k);
    ht::Tet tets[8];
    const int n = ht::diamond_tets(c, di, int32_t(int64_t{1} << G.k), tets);
    const int64_t h = int64_t{1} << t;
    auto known = [&](const ht::Pt& p) {
        bool coarse = true;
        for (int a = 0; a < 3; ++a) {
            if (p[a] < 0 || p[a] > G.box_max[a]) return false;
            if (p[a] & h) coarse = false;
        }
        if (coarse) return true;
        for (int a = 0; a < 3; ++a)
            if (p[a] < cb[a] || p[a] > cb[3 + a]) return false;
        return true;
    };
    static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    double best = 0.0;
    for (int i = 0; i < n; ++i) {
        const ht::Tet& T4 = tets[i];
        bool inside = true;
        for (const auto& p : T4)
            for (int a = 0; a < 3; ++a) inside = inside && p[a] >= 0 && p[a] <= G.box_max[a];
        if (!inside) continue;
        for (const auto& e : kEdges) {
            const ht::Pt& a = T4[e[0]];
            const ht::Pt& b = T4[e[1]];
            ht::Pt p;
            bool lattice = true;
            for (int q = 0; q < 3; ++q) {
                const int64_t s2 = int64_t(a[q]) + b[q];
                if ((s2 & (2 * h - 1)) != 0) lattice = false;
                p[q] = int32_t(s2 / 2);
            }
            if (!lattice || !known(p) || !known(a) || !known(b)) continue;
            const double fa = static_cast<double>(v[G.index(a[0], a[1], a[2])]);
            const double fb = static_cast<double>(v[G.index(b[0], b[1], b[2])]);
            const double fp = static_cast<double>(v[G.index(p[0], p[1], p[2])]);
            const double d = std::fabs(fp - 0.5 * (fa + fb));
            if (!(d <= best) && !std::isnan(best)) best = d;  // a NaN wins and stays
        }
    }
    return quantize_error(static_cast<float>(best), m);
}

/// lattice_bound_code for a diamond in the chunk interior (ChunkFrame::interior):
/// all its tets are in B and every point they touch is available, so the scan
/// is the closed-form edge list of its sign pattern over precomputed offsets.
/// For integer types |f(m) - (f(a) + f(b))/2| = |2 f(m) - f(a) - f(b)| / 2 exactly.
template <class T>
uint32_t lattice_bound_interior(const T* c, const DiamondEdges& E, const int64_t off[27], int m) {
    if constexpr (std::is_integral_v<T>) {
        int64_t best = 0;
        for (int i = 0; i < E.n; ++i) {
            const int64_t d = 2 * int64_t(c[off[E.m[i]]]) - int64_t(c[off[E.a[i]]]) - int64_t(c[off[E.b[i]]]);
            best = std::max(best, d < 0 ? -d : d);
        }
        return quantize_error(static_cast<float>(double(best) * 0.5), m);
    } else {
        double best = 0.0;
        for (int i = 0; i < E.n; ++i) {
            const double fa = static_cast<double>(c[off[E.a[i]]]);
            const double fb = static_cast<double>(c[off[E.b[i]]]);
            const double fp = static_cast<double>(c[off[E.m[i]]]);
            const double d = std::fabs(fp - 0.5 * (fa + fb));
            if (std::isnan(d)) return quantize_error(std::numeric_limits<float>::quiet_NaN(), m);
            best = std::max(best, d);
        }
        return quantize_error(static_cast<float>(best), m);
    }
}

/// lattice_bound_code for a diamond inside B (c ± h in B) near its chunk's
/// faces: the closed-form edge list, skipping edges with a point that is not
/// available (neither coarser than cycle t nor in the chunk's box).
template <class T>
uint32_t lattice_bound_near_face(const T* c, const DiamondEdges& E, const int64_t off[27], uint32_t avail, int m) {
    double best = 0.0;
    for (int i = 0; i < E.n; ++i) {
        if (!((avail >> E.a[i]) & (avail >> E.b[i]) & (avail >> E.m[i]) & 1u)) continue;
        const double fa = static_cast<double>(c[off[E.a[i]]]);
        const double fb = static_cast<double>(c[off[E.b[i]]]);
        const double fp = static_cast<double>(c[off[E.m[i]]]);
        const double d = std::fabs(fp - 0.5 * (fa + fb));
        if (std::isnan(d)) return quantize_error(std::numeric_limits<float>::quiet_NaN(), m);
        best = std::max(best, d);
    }
    return quantize_error(static_cast<float>(best), m);
}

template <class T>
uint32_t lattice_bound_point(const Geometry& G, const T* v, const ChunkFrame& F, int t, int64_t x, int64_t y,
                             int64_t z, int64_t idx, int m) {
    const DiamondEdges& E = diamond_edge_table().by_sig[sig_code(x, y, z, F.h)];
    if (F.interior(x, y, z)) return lattice_bound_interior(v + idx, E, F.off, m);
    const int64_t h = F.h;
    const int64_t c[3] = {x, y, z};
    bool in_b = true;
    for (int a = 0; a < 3; ++a) in_b = in_b && c[a] - h >= 0 && c[a] + h <= G.box_max[a];
    if (!in_b) return lattice_bound_code(G, v, t, x, y, z, F.cb, m);
    // Per axis and offset o in {-1, 0, 1}: coarse (even multiple of h) and in the chunk's box.
    bool even[3][3], inside[3][3];
    for (int a = 0; a < 3; ++a)
        for (int o = -1; o <= 1; ++o) {
            const int64_t p = c[a] + o * h;
            even[a][o + 1] = (p & h) == 0;
            inside[a][o + 1] = p >= F.cb[a] && p <= F.cb[3 + a];
        }
    uint32_t avail = 0;
    for (int oz = 0; oz < 3; ++oz)
        for (int oy = 0; oy < 3; ++oy)
            for (int ox = 0; ox < 3; ++ox)
                if ((even[0][ox] && even[1][oy] && even[2][oz]) || (inside[0][ox] && inside[1][oy] && inside[2][oz]))
                    avail |= 1u << (ox + 3 * oy + 9 * oz);
    return lattice_bound_near_face(v + idx, E, F.off, avail, m);
}

template <class T>
std::vector<std::byte> encode_error_chunk_v2(const Geometry& G, const T* v, const std::vector<float>& e,
                                             const HtChunk& c, int m) {
    std::vector<std::byte> out;
    if (c.diamonds == 0) return out;
    auto models = std::make_unique<ErrorModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    rc::Encoder enc(out);
    const uint32_t qmax = max_error_code(m);
    for_each_point_v2(G, c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z, int cls) {
        const int far = touches_far_face(G, c.cycle, x, y, z);
        const uint32_t q = quantize_error(e[G.index(x, y, z)], m);
        enc.encode(models->inf[cls][far], q == qmax);
        if (q == qmax) {
            lat.set(lat.slot(x, y, z), 0);
            return;
        }
        const uint32_t lb = lattice_bound_point(G, v, F, c.cycle, x, y, z, G.index(x, y, z), m);
        const int64_t delta = int64_t(q) - int64_t(lb);
        const uint64_t mag = uint64_t(delta < 0 ? -delta : delta);
        const int nb = std::min(5, rc::bit_length(lat.neighbour_mean(lat.slot(x, y, z))));
        rc::encode_int(enc, models->m[cls][lb != 0][nb], mag, delta < 0, 16);
        lat.set(lat.slot(x, y, z), mag);
    });
    enc.finish();
    return out;
}

/// False on a malformed stream or a code out of range.
template <class T>
bool decode_error_chunk_v2(const Geometry& G, const T* v, ZeroedVector<float>& e, const HtChunk& c, int m,
                           std::span<const std::byte> in) {
    if (c.diamonds == 0) return in.empty();
    auto models = std::make_unique<ErrorModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    rc::Decoder dec(in.data(), in.size());
    const uint32_t qmax = max_error_code(m);
    bool ok = true;
    for_each_point_v2(G, c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z, int cls) {
        if (dec.overrun()) return;  // a valid stream never reads past its end: stop early
        const int far = touches_far_face(G, c.cycle, x, y, z);
        float& out = e[G.index(x, y, z)];
        if (dec.decode(models->inf[cls][far])) {
            out = std::numeric_limits<float>::infinity();
            lat.set(lat.slot(x, y, z), 0);
            return;
        }
        const uint32_t lb = lattice_bound_point(G, v, F, c.cycle, x, y, z, G.index(x, y, z), m);
        const int nb = std::min(5, rc::bit_length(lat.neighbour_mean(lat.slot(x, y, z))));
        uint64_t mag;
        bool neg;
        rc::decode_int(dec, models->m[cls][lb != 0][nb], mag, neg, 16);
        const int64_t q = int64_t(lb) + (neg ? -int64_t(mag) : int64_t(mag));
        if (q < 0 || q >= int64_t(qmax) || (neg && mag == 0)) {
            ok = false;
            out = std::numeric_limits<float>::infinity();
        } else {
            out = dequantize_error(uint16_t(q), m);
        }
        lat.set(lat.slot(x, y, z), mag);
    });
    return ok && !dec.bad_end();
}

std::vector<std::byte> ht_header_bytes(const HtDomain& d, int g, int m) {
    std::vector<std::byte> h;
    tlod::put_u8(h, uint8_t(d.k));
    tlod::put_u8(h, d.padded ? 1 : 0);
    tlod::put_u8(h, uint8_t(g));
    tlod::put_u8(h, uint8_t(m));
    tlod::put_u8(h, kPredictorNeighbours);
    tlod::put_u8(h, kResidualRangeCoder);
    tlod::put_u16(h, 0);
    for (int a = 0; a < 3; ++a) tlod::put_u32(h, uint32_t(d.box_max[a]));
    tlod::put_u32(h, 0);
    return h;
}

}  // namespace

uint16_t quantize_error(float error, int m) {
    const int shift = 23 - m;
    if (std::isnan(error) || error == std::numeric_limits<float>::infinity())
        return uint16_t(max_error_code(m));
    if (!(error > 0.0f)) return 0;
    const uint32_t bits = std::bit_cast<uint32_t>(error);
    const uint32_t q = (bits + ((uint32_t{1} << shift) - 1)) >> shift;
    return uint16_t(std::min(q, max_error_code(m)));
}

float dequantize_error(uint16_t code, int m) {
    return std::bit_cast<float>(uint32_t(code) << (23 - m));
}

void encode_ht(const HtModel& model, const tlod::Metadata& meta, tlod::ContainerWriter& writer,
               const HtEncodeOptions& o) {
    if (o.brick_log2 < 1 || o.brick_log2 > 16)
        throw Error(ErrorCode::InvalidArgument, "brick_log2 must be in 1..16");
    if (o.error_mantissa_bits < 0 || o.error_mantissa_bits > 7)
        throw Error(ErrorCode::InvalidArgument, "error mantissa bits must be in 0..7");
    const HtDomain& d = model.domain();
    const Volume& f = model.field();
    if (f.type != meta.type || !(d.source_dims == meta.dims))
        throw Error(ErrorCode::InvalidArgument, "metadata does not describe the model's volume");
    const Geometry G = geometry_of(d, o.brick_log2);
    const std::vector<HtChunk> chunks = chunk_list(G);
    const int m = o.error_mantissa_bits;

    // Informative summary of the stored error bounds (spec §5.3), so `info`
    // reports them without decoding any chunk.
    tlod::Metadata md = meta;
    {
        float emax = 0;
        uint64_t always = 0;
        const auto& e = model.diamond_errors();
        for (float v : e) {
            const float q = dequantize_error(quantize_error(v, m), m);
            if (std::isinf(q)) ++always;
            else emax = std::max(emax, q);
        }
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.9g", double(emax));
        md.format_keys[tlod::kKeyHtErrorMax] = buf;
        md.format_keys[tlod::kKeyHtAlwaysSplit] = std::to_string(always);
    }
    writer.set_features(tlod::kFeatureHt);
    writer.add(tlod::kSectionMetadata, tlod::kSectionCritical, 0, 0, tlod::serialize_metadata(md),
               o.zstd_level);
    const auto hh = ht_header_bytes(d, o.brick_log2, m);
    writer.add_stored(tlod::kSectionHtHeader, tlod::kSectionCritical, 0, 0, hh, hh.size());

    std::vector<std::vector<std::byte>> fs(chunks.size()), es(chunks.size());
    std::vector<uint64_t> fraw(chunks.size()), eraw(chunks.size());
    // Parallel over chunks in batches so progress is reported from this thread.
    const std::size_t batch = 64;
    for (std::size_t s = 0; s < chunks.size(); s += batch) {
        const std::size_t e = std::min(chunks.size(), s + batch);
        tbb::parallel_for(s, e, [&](std::size_t i) {
            auto raw = dispatch_value_type(f.type, [&](auto tv) {
                using T = decltype(tv);
                return encode_field_chunk_v2<T>(G, f.as<T>(), chunks[i]);
            });
            fraw[i] = raw.size();
            fs[i] = std::move(raw);
            auto er = dispatch_value_type(f.type, [&](auto tv) {
                using T = decltype(tv);
                return encode_error_chunk_v2<T>(G, f.as<T>(), model.diamond_errors(), chunks[i], m);
            });
            eraw[i] = er.size();
            es[i] = std::move(er);
        });
        if (o.progress) o.progress(e, chunks.size());
    }
    for (std::size_t i = 0; i < chunks.size(); ++i) {
        writer.add_stored(tlod::kSectionHtField, tlod::kSectionCritical,
                          uint32_t(chunks[i].cycle), chunks[i].brick, std::move(fs[i]), fraw[i]);
        writer.add_stored(tlod::kSectionHtErrors, tlod::kSectionCritical,
                          uint32_t(chunks[i].cycle), chunks[i].brick, std::move(es[i]), eraw[i]);
    }
}

void write_ht_container(const std::string& path, const HtModel& model, const tlod::Metadata& meta,
                        const HtEncodeOptions& options) {
    tlod::ContainerWriter w;
    encode_ht(model, meta, w, options);
    w.write(path);
}

Expected<HtLayout> read_ht_layout(tlod::ContainerReader& r) {
    const std::string where = r.name() + ": ";
    if (!(r.header().required_features & tlod::kFeatureHt))
        return fail(ErrorCode::NotFound, where + "the container holds no HT model");
    const auto& secs = r.sections();
    // Known sections in their required order; unknown non-critical ones skipped.
    std::vector<std::size_t> known;
    // (The MT's sections, spec §10, follow the HT's and are not part of its layout.)
    for (std::size_t i = 0; i < secs.size(); ++i)
        if (tlod::is_known_section_type(secs[i].type) && secs[i].type <= tlod::kSectionHtErrors)
            known.push_back(i);
    if (known.empty() || secs[known[0]].type != tlod::kSectionMetadata)
        return fail(ErrorCode::CorruptData, where + "METADATA must be the first known section");
    auto mraw = r.read_section(known[0]);
    if (!mraw) return mraw.failure();
    auto meta = tlod::parse_metadata(*mraw);
    if (!meta) return fail(meta.failure().code, where + meta.failure().message);
    if (known.size() < 2 || secs[known[1]].type != tlod::kSectionHtHeader)
        return fail(ErrorCode::CorruptData, where + "HT_HEADER must follow METADATA");
    auto hraw = r.read_section(known[1]);
    if (!hraw) return hraw.failure();
    if (hraw->size() != kHtHeaderSize)
        return fail(ErrorCode::CorruptData, where + "HT_HEADER has " + std::to_string(hraw->size()) +
                                                " bytes, expected " + std::to_string(kHtHeaderSize));
    tlod::ByteReader b(*hraw);
    HtLayout L;
    L.metadata = std::move(*meta);
    const int k = b.u8();
    const uint8_t flags = b.u8();
    L.brick_log2 = b.u8();
    L.error_mantissa_bits = b.u8();
    const uint8_t predictor = b.u8();
    const uint8_t coding = b.u8();
    const uint16_t res0 = b.u16();
    uint32_t box[3];
    for (auto& v : box) v = b.u32();
    const uint32_t res1 = b.u32();
    if (flags & ~1u) return fail(ErrorCode::CorruptData, where + "HT_HEADER: reserved flag bits set");
    if (res0 || res1) return fail(ErrorCode::CorruptData, where + "HT_HEADER: reserved fields not zero");
    if (!(predictor == kPredictorCoarseMean && coding == kResidualZigzagPlanes) &&
        !(predictor == kPredictorNeighbours && coding == kResidualRangeCoder))
        return fail(ErrorCode::UnsupportedFeature, where + "HT_HEADER: unknown predictor or residual coding");
    L.residual_coding = coding;
    if (L.brick_log2 < 1 || L.brick_log2 > 16 || L.error_mantissa_bits > 7)
        return fail(ErrorCode::CorruptData, where + "HT_HEADER: brick size or error precision out of range");
    const Dims& dims = L.metadata.dims;
    if (dims.x < 2 || dims.y < 2 || dims.z < 2)
        return fail(ErrorCode::CorruptData, where + "an HT needs at least 2 samples per axis");
    HtDomain d;
    try {
        d = HtDomain::for_dims(dims, flags & 1);
    } catch (const Error& e) {
        return fail(e.code(), where + e.what());
    }
    if (d.k != k || uint32_t(d.box_max[0]) != box[0] || uint32_t(d.box_max[1]) != box[1] ||
        uint32_t(d.box_max[2]) != box[2])
        return fail(ErrorCode::CorruptData, where + "HT_HEADER: k or box does not match the volume dims");
    validate_dims(d.dims(), "HT box");
    L.domain = d;
    const Geometry G = geometry_of(d, L.brick_log2);
    // Cheap bound on the chunk count before building the list: each chunk needs
    // two table entries, so a table that is too short is refused here.
    uint64_t expect = 0;
    for (int t = G.k; t >= 0; --t) {
        auto n = G.bricks(t);
        expect += uint64_t(n[0] * n[1] * n[2]);
    }
    if (expect * 2 > known.size() - 2)
        return fail(ErrorCode::CorruptData, where + "the file has " + std::to_string(known.size() - 2) +
                                                " HT chunk sections, the HT_HEADER needs " +
                                                std::to_string(expect * 2));
    L.chunks = chunk_list(G);
    if (L.chunks.size() * 2 != known.size() - 2)
        return fail(ErrorCode::CorruptData, where + "extra sections after the last HT chunk");
    const int W = int(value_size(L.metadata.type));
    for (std::size_t i = 0; i < L.chunks.size(); ++i) {
        HtChunk& c = L.chunks[i];
        c.field_section = known[2 + 2 * i];
        c.error_section = known[3 + 2 * i];
        const auto& fs = secs[c.field_section];
        const auto& es = secs[c.error_section];
        if (fs.type != tlod::kSectionHtField || es.type != tlod::kSectionHtErrors ||
            fs.arg0 != uint32_t(c.cycle) || es.arg0 != uint32_t(c.cycle) || fs.arg1 != c.brick ||
            es.arg1 != c.brick)
            return fail(ErrorCode::CorruptData, where + "section " + std::to_string(c.field_section) +
                                                    ": HT chunks out of order (expected cycle " +
                                                    std::to_string(c.cycle) + " brick " +
                                                    std::to_string(c.brick) + ")");
        if (L.residual_coding == kResidualZigzagPlanes) {
            if (fs.raw_size != c.points * W || es.raw_size != c.diamonds * 2)
                return fail(ErrorCode::CorruptData, where + "section " + std::to_string(c.field_section) +
                                                        ": raw size does not match the chunk's point count");
            continue;
        }
        // Coding 2 (spec §7.5): stored range-coder streams, never zstd; the
        // point count is bounded by the stream length before anything is allocated.
        for (const auto& [si, count] : {std::pair{c.field_section, c.points}, std::pair{c.error_section, c.diamonds}}) {
            const auto& s = secs[si];
            const std::string sec = where + "section " + std::to_string(si) + ": ";
            if (s.flags & tlod::kSectionZstd)
                return fail(ErrorCode::CorruptData, sec + "range-coded HT chunks must not be zstd-compressed");
            if ((count == 0) != (s.raw_size == 0) || (count > 0 && s.raw_size < 5))
                return fail(ErrorCode::CorruptData, sec + "coded size " + std::to_string(s.raw_size) +
                                                        " impossible for " + std::to_string(count) + " values");
            if (count > kMaxPointsPerByte * s.raw_size)
                return fail(ErrorCode::CorruptData, sec + std::to_string(count) + " values cannot fit in " +
                                                        std::to_string(s.raw_size) + " coded bytes");
        }
    }
    return L;
}

namespace {

/// Adds to `want` every chunk the wanted ones depend on: per cycle, the coarser
/// chunks meeting the wanted chunks' boxes grown by the predictor reach (2^t
/// at cycle t, spec §6.3). `want` is indexed like L.chunks (file order).
void add_dependencies(const HtLayout& L, std::vector<char>& want) {
    // Wanted boxes of the current cycle, grown as we go coarser.
    std::vector<std::array<int64_t, 6>> region;
    std::size_t i = L.chunks.size();
    while (i > 0) {  // from the finest cycle (end of the list) to the coarsest
        std::size_t b = i;
        while (b > 0 && L.chunks[b - 1].cycle == L.chunks[i - 1].cycle) --b;
        const int t = L.chunks[b].cycle;
        for (std::size_t j = b; j < i; ++j) {
            const HtChunk& c = L.chunks[j];
            if (!want[j])
                for (const auto& g : region) {
                    bool meet = true;
                    for (int a = 0; a < 3; ++a)
                        meet = meet && c.box[a] <= g[3 + a] && g[a] <= c.box[3 + a];
                    if (meet) {
                        want[j] = 1;
                        break;
                    }
                }
        }
        const int64_t h = int64_t{1} << t;
        for (auto& g : region)
            for (int a = 0; a < 3; ++a) g[a] -= h, g[3 + a] += h;
        for (std::size_t j = b; j < i; ++j) {
            if (!want[j]) continue;
            auto g = L.chunks[j].box;
            for (int a = 0; a < 3; ++a) g[a] -= h, g[3 + a] += h;
            region.push_back(g);
        }
        i = b;
    }
}

/// Decodes the wanted chunks not yet decoded (`done`), cycle by cycle, into
/// `field` / `errors` (errors when non-null). Dependencies must be wanted too.
Expected<uint64_t> decode_chunks(tlod::ContainerReader& r, const HtLayout& L, const std::vector<char>& want,
                                 std::vector<char>& done, Volume& field, ZeroedVector<float>* errors) {
    const Geometry G = geometry_of(L.domain, L.brick_log2);
    const int m = L.error_mantissa_bits;
    uint64_t decoded = 0;
    std::size_t i = 0;
    while (i < L.chunks.size()) {
        std::size_t e = i;
        while (e < L.chunks.size() && L.chunks[e].cycle == L.chunks[i].cycle) ++e;
        std::vector<std::size_t> ids;
        for (std::size_t j = i; j < e; ++j)
            if (want[j] && !done[j]) ids.push_back(j);
        std::vector<std::vector<std::byte>> fst(ids.size()), est(ids.size());
        for (std::size_t j = 0; j < ids.size(); ++j) {
            auto s = r.read_stored(L.chunks[ids[j]].field_section);
            if (!s) return s.failure();
            fst[j] = std::move(*s);
            if (errors) {
                auto s2 = r.read_stored(L.chunks[ids[j]].error_section);
                if (!s2) return s2.failure();
                est[j] = std::move(*s2);
            }
        }
        std::vector<Failure> fails(ids.size(), Failure{ErrorCode::Ok, {}});
        tbb::parallel_for(std::size_t(0), ids.size(), [&](std::size_t j) {
            const HtChunk& c = L.chunks[ids[j]];
            const auto& fsec = r.sections()[c.field_section];
            auto unpack = [](std::vector<std::byte>& st, const tlod::SectionInfo& si)
                -> Expected<std::vector<std::byte>> {
                if (!(si.flags & tlod::kSectionZstd)) return std::move(st);
                return tlod::zstd_decompress(st, si.raw_size);
            };
            auto raw = unpack(fst[j], fsec);
            if (!raw) {
                fails[j] = fail(raw.failure().code, r.name() + ": section " +
                                                        std::to_string(c.field_section) + ": " +
                                                        raw.failure().message);
                return;
            }
            const bool field_ok = dispatch_value_type(field.type, [&](auto tv) {
                using T = decltype(tv);
                if (L.residual_coding == kResidualZigzagPlanes) {
                    decode_field_chunk<T>(G, field.as<T>(), c, raw->data());
                    return true;
                }
                return decode_field_chunk_v2<T>(G, field.as<T>(), c, *raw);
            });
            if (!field_ok) {
                fails[j] = fail(ErrorCode::CorruptData, r.name() + ": section " +
                                                            std::to_string(c.field_section) +
                                                            ": malformed range-coded stream");
                return;
            }
            if (!errors) return;
            auto er = unpack(est[j], r.sections()[c.error_section]);
            if (!er) {
                fails[j] = fail(er.failure().code, r.name() + ": section " +
                                                       std::to_string(c.error_section) + ": " +
                                                       er.failure().message);
                return;
            }
            const bool codes_ok = dispatch_value_type(field.type, [&](auto tv) {
                using T = decltype(tv);
                if (L.residual_coding == kResidualZigzagPlanes)
                    return decode_error_chunk<T>(G, field.as<T>(), *errors, c, m, er->data());
                return decode_error_chunk_v2<T>(G, field.as<T>(), *errors, c, m, *er);
            });
            if (!codes_ok)
                fails[j] = fail(ErrorCode::CorruptData, r.name() + ": section " +
                                                            std::to_string(c.error_section) +
                                                            ": error code out of range or malformed stream");
        });
        for (const Failure& f : fails)
            if (f.code != ErrorCode::Ok) return f;
        for (std::size_t j : ids) done[j] = 1;
        decoded += ids.size();
        i = e;
    }
    return decoded;
}

void restore_metadata(Volume& field, const tlod::Metadata& md) {
    field.spacing = md.spacing;
    field.origin = md.origin;
    field.field_name = md.field_name();
    field.units = md.units();
    field.metadata = md.user_keys;
}

}  // namespace

Expected<HtDecoded> decode_ht(tlod::ContainerReader& r, const HtDecodeRequest& req) {
    auto layout = read_ht_layout(r);
    if (!layout) return layout.failure();
    HtDecoded out;
    out.layout = std::move(*layout);
    const HtLayout& L = out.layout;
    const Geometry G = geometry_of(L.domain, L.brick_log2);
    std::vector<char> want(L.chunks.size(), 0), done(L.chunks.size(), 0);
    const std::array<int64_t, 6> region = req.box.value_or(std::array<int64_t, 6>{
        0, 0, 0, G.box_max[0], G.box_max[1], G.box_max[2]});
    for (std::size_t i = 0; i < L.chunks.size(); ++i) {
        const HtChunk& c = L.chunks[i];
        if (c.cycle < req.finest_cycle) continue;
        bool meet = true;
        for (int a = 0; a < 3; ++a) meet = meet && c.box[a] <= region[3 + a] && region[a] <= c.box[3 + a];
        want[i] = meet;
    }
    add_dependencies(L, want);
    // Field and errors start as untouched zero pages (ZeroedVector): a file that
    // fails in its first chunks costs only the pages decoded so far, not the grid
    // its header claims. Cube corners are not diamonds: their error stays 0.
    Volume field;
    ZeroedVector<float> errors;
    try {
        field = Volume::allocate(L.domain.dims(), L.metadata.type);
        if (req.errors) errors.resize(std::size_t(field.count()));
    } catch (const std::bad_alloc&) {
        return fail(ErrorCode::TooLarge, r.name() + ": cannot allocate the decoded field");
    } catch (const Error& e) {
        return fail(e.code(), r.name() + ": " + e.what());
    }
    auto n = decode_chunks(r, L, want, done, field, req.errors ? &errors : nullptr);
    if (!n) return n.failure();
    out.chunks_decoded = *n;
    if (req.errors) {
        // Diamonds of chunks left out of the request have no bound: +inf.
        for (std::size_t i = 0; i < L.chunks.size(); ++i)
            if (!done[i])
                G.for_each_point(L.chunks[i].cycle, L.chunks[i].box, [&](int64_t x, int64_t y, int64_t z) {
                    errors[G.index(x, y, z)] = std::numeric_limits<float>::infinity();
                });
        try {
            out.errors.assign(errors.begin(), errors.end());
        } catch (const std::bad_alloc&) {
            return fail(ErrorCode::TooLarge, r.name() + ": cannot allocate the decoded errors");
        }
    }
    restore_metadata(field, L.metadata);
    out.field = std::move(field);
    return out;
}

Expected<TetMesh> extract_ht_lazy(tlod::ContainerReader& r, const LodQuery& query, HtExtractStats* es,
                                  HtLazyStats* ls) {
    auto layout = read_ht_layout(r);
    if (!layout) return layout.failure();
    const HtLayout& L = *layout;
    const Geometry G = geometry_of(L.domain, L.brick_log2);
    std::vector<char> want(L.chunks.size(), 0), done(L.chunks.size(), 0);
    Volume field;
    ZeroedVector<float> errors;
    try {
        // Untouched zero pages until decoded (see decode_ht). Undecoded diamonds
        // read as error 0 ("fine"): the refinement then stops at them, and the
        // check below finds every such stop and loads it.
        field = Volume::allocate(L.domain.dims(), L.metadata.type);
        errors.resize(std::size_t(field.count()));
    } catch (const std::bad_alloc&) {
        return fail(ErrorCode::TooLarge, r.name() + ": cannot allocate the decoded field");
    } catch (const Error& e) {
        return fail(e.code(), r.name() + ": " + e.what());
    }
    restore_metadata(field, L.metadata);
    // Chunk of a grid point of B: cycle from the trailing zeros, brick from the coordinates.
    std::vector<std::size_t> first_of_cycle(std::size_t(G.k + 1), 0);
    for (std::size_t i = L.chunks.size(); i-- > 0;) first_of_cycle[std::size_t(L.chunks[i].cycle)] = i;
    auto chunk_of = [&](const std::array<int32_t, 3>& p) -> std::size_t {
        int t = G.k;
        for (int a = 0; a < 3; ++a)
            if (p[a] != 0) t = std::min(t, std::countr_zero(uint32_t(p[a])));
        const auto n = G.bricks(t);
        int64_t bi[3];
        for (int a = 0; a < 3; ++a) bi[a] = std::min<int64_t>(p[a] / G.side(t), n[a] - 1);
        return first_of_cycle[std::size_t(t)] + std::size_t((bi[2] * n[1] + bi[1]) * n[0] + bi[0]);
    };
    // Start with the three coarsest cycles (a small prefix of the file).
    for (std::size_t i = 0; i < L.chunks.size(); ++i) want[i] = L.chunks[i].cycle >= G.k - 2;
    HtLazyStats st;
    st.chunks_total = L.chunks.size();
    const int max_level = 3 * G.k;
    for (;;) {
        add_dependencies(L, want);
        auto n = decode_chunks(r, L, want, done, field, &errors);
        if (!n) return n.failure();
        st.chunks_decoded += *n;
        ++st.passes;
        HtModel model;
        try {
            model = HtModel::from_parts(field, L.domain, std::vector<float>(errors.begin(), errors.end()));
        } catch (const Error& e) {
            return fail(e.code(), r.name() + ": " + e.what());
        }
        TetMesh mesh = model.extract(query, es);
        // The mesh is the true one iff every vertex and the diamond under every
        // non-finest tet (centred at its longest edge's midpoint, the one the
        // refinement judged) are decoded.
        bool missing = false;
        auto need = [&](const std::array<int32_t, 3>& p) {
            const std::size_t c = chunk_of(p);
            if (!done[c]) {
                want[c] = 1;
                missing = true;
            }
        };
        for (const auto& p : mesh.points) need(p);
        for (std::size_t ti = 0; ti < mesh.tets.size(); ++ti) {
            if (mesh.level[ti] >= max_level) continue;
            const auto& tv = mesh.tets[ti];
            int64_t best = -1;
            std::array<int32_t, 3> mid{};
            for (int a = 0; a < 4; ++a)
                for (int b = a + 1; b < 4; ++b) {
                    const auto& P = mesh.points[tv[a]];
                    const auto& Q = mesh.points[tv[b]];
                    int64_t d2 = 0;
                    for (int q = 0; q < 3; ++q) d2 += int64_t(P[q] - Q[q]) * (P[q] - Q[q]);
                    if (d2 > best) {
                        best = d2;
                        for (int q = 0; q < 3; ++q) mid[q] = (P[q] + Q[q]) / 2;
                    }
                }
            if (L.domain.in_box(mid[0], mid[1], mid[2])) need(mid);
        }
        if (!missing) {
            st.bytes_read = r.bytes_read();
            if (ls) *ls = st;
            return mesh;
        }
    }
}

Expected<Volume> decode_volume(tlod::ContainerReader& r) {
    HtDecodeRequest req;
    req.errors = false;
    auto d = decode_ht(r, req);
    if (!d) return d.failure();
    Volume& f = d->field;
    const Dims src = d->layout.metadata.dims;
    if (f.dims == src) return std::move(f);
    Volume out = Volume::allocate(src, f.type);
    const std::size_t w = value_size(f.type);
    for (int64_t z = 0; z < src.z; ++z)
        for (int64_t y = 0; y < src.y; ++y)
            std::memcpy(out.data.data() + std::size_t(src.index(0, y, z)) * w,
                        f.data.data() + std::size_t(f.dims.index(0, y, z)) * w, std::size_t(src.x) * w);
    out.spacing = f.spacing;
    out.origin = f.origin;
    out.field_name = f.field_name;
    out.units = f.units;
    out.metadata = f.metadata;
    return out;
}

HtModel load_ht_model(const std::string& path) {
    auto r = tlod::ContainerReader::open(path);
    if (!r) throw Error(r.failure().code, r.failure().message);
    auto d = decode_ht(*r);
    if (!d) throw Error(d.failure().code, d.failure().message);
    return HtModel::from_parts(std::move(d->field), d->layout.domain, std::move(d->errors));
}

bool is_tlod_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    char m[8] = {};
    if (!in.read(m, 8)) return false;
    return std::memcmp(m, tlod::kMagic, 8) == 0;
}

}  // namespace tetlod
