// Rasterisation of a TetMesh onto the grid (see mesh_resample.hpp).
#include "tetlod/analysis/mesh_resample.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"

namespace tetlod {

namespace {

using i128 = __int128;

// det(b - a, c - a, d - a) exactly.
i128 signed_volume(const std::array<std::array<int64_t, 3>, 4>& v) {
    const i128 ax = v[1][0] - v[0][0], ay = v[1][1] - v[0][1], az = v[1][2] - v[0][2];
    const i128 bx = v[2][0] - v[0][0], by = v[2][1] - v[0][1], bz = v[2][2] - v[0][2];
    const i128 cx = v[3][0] - v[0][0], cy = v[3][1] - v[0][1], cz = v[3][2] - v[0][2];
    return ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
}

// floor(a / b), b > 0.
template <class I>
I floor_div(I a, I b) {
    I q = a / b;
    if (a % b != 0 && a < 0) --q;
    return q;
}
template <class I>
I ceil_div(I a, I b) { return -floor_div<I>(-a, b); }

constexpr i128 kI64Max = std::numeric_limits<int64_t>::max();

template <class T>
struct Writer {
    T* out;
    bool exact_ints;  // integer type and integer vertex values: the rational path

    template <class I>
    void put(int64_t idx, const std::array<I, 4>& n, I d, const std::array<double, 4>& f,
             const std::array<int64_t, 4>& fi) const {
        if constexpr (std::is_integral_v<T>) {
            if (exact_ints) {
                i128 num = 0;
                for (int i = 0; i < 4; ++i) num += i128(n[i]) * fi[i];
                // round(num / d), ties towards +inf: floor((2 num + d) / (2 d)); 64-bit
                // division whenever the operands fit (the common case).
                const i128 a = 2 * num + i128(d), b = 2 * i128(d);
                i128 r;
                if (a <= kI64Max && a >= -kI64Max && b <= kI64Max)
                    r = floor_div<int64_t>(int64_t(a), int64_t(b));
                else
                    r = floor_div<i128>(a, b);
                r = std::clamp<i128>(r, std::numeric_limits<T>::min(), std::numeric_limits<T>::max());
                out[idx] = T(r);
                return;
            }
        }
        const double dd = double(d);
        double v = 0.0;
        for (int i = 0; i < 4; ++i)
            if (n[i] != 0) v += (double(n[i]) / dd) * f[i];
        if constexpr (std::is_integral_v<T>) {
            const double r = std::floor(v + 0.5);
            const double lo = double(std::numeric_limits<T>::min());
            const double hi = double(std::numeric_limits<T>::max());
            out[idx] = T(std::isnan(r) ? 0.0 : std::clamp(r, lo, hi));
        } else {
            out[idx] = T(v);
        }
    }
};

// One tet, vertices sorted by id, coordinates relative to its bounding box's low
// corner `lo` (extents `ext`). I = int64_t when every extent is <= 2^20 (then all
// numerators, at any point of the bounding box, stay below 2^63), else __int128.
template <class I, class T>
void scan_tet(const std::array<std::array<int64_t, 3>, 4>& P, i128 D128,
              const std::array<int64_t, 3>& lo, const std::array<int64_t, 3>& hi,
              const std::array<double, 4>& f, const std::array<int64_t, 4>& fi, const Writer<T>& w,
              const Dims& dims, std::vector<uint8_t>& covered, MeshResampleStats& st) {
    // N_i(p) = g_i . p + c_i: g_i is the normal of the face opposite v_i, oriented so
    // that N_i(v_i) = D; c_i = -g_i . (a vertex of that face).
    std::array<std::array<I, 3>, 4> g;
    std::array<I, 4> c;
    I D = I(D128);
    for (int i = 0; i < 4; ++i) {
        const auto& a = P[(i + 1) & 3];
        const auto& b = P[(i + 2) & 3];
        const auto& e = P[(i + 3) & 3];
        const I ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
        const I vx = e[0] - a[0], vy = e[1] - a[1], vz = e[2] - a[2];
        std::array<I, 3> n{uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
        const I s = n[0] * (P[i][0] - a[0]) + n[1] * (P[i][1] - a[1]) + n[2] * (P[i][2] - a[2]);
        if ((s < 0) != (D < 0))
            for (auto& x : n) x = -x;
        g[i] = n;
        c[i] = -(n[0] * a[0] + n[1] * a[1] + n[2] * a[2]);
    }
    if (D < 0) {
        D = -D;
        for (int i = 0; i < 4; ++i) {
            c[i] = -c[i];
            for (int k = 0; k < 3; ++k) g[i][k] = -g[i][k];
        }
    }
    // Clip the bounding box to the grid.
    const int64_t z0 = std::max<int64_t>(lo[2], 0), z1 = std::min<int64_t>(hi[2], dims.z - 1);
    const int64_t y0 = std::max<int64_t>(lo[1], 0), y1 = std::min<int64_t>(hi[1], dims.y - 1);
    const int64_t xa = std::max<int64_t>(lo[0], 0), xb = std::min<int64_t>(hi[0], dims.x - 1);
    if (xa > xb) return;
    for (int64_t z = z0; z <= z1; ++z)
        for (int64_t y = y0; y <= y1; ++y) {
            ++st.rows_scanned;
            std::array<I, 4> r;
            I xl = xa - lo[0], xh = xb - lo[0];  // relative x interval
            for (int i = 0; i < 4; ++i) {
                r[i] = c[i] + g[i][1] * I(y - lo[1]) + g[i][2] * I(z - lo[2]);
                const I gx = g[i][0];
                if (gx > 0)
                    xl = std::max(xl, ceil_div<I>(-r[i], gx));
                else if (gx < 0)
                    xh = std::min(xh, floor_div<I>(r[i], -gx));
                else if (r[i] < 0)
                    xh = xl - 1;
            }
            if (xl > xh) continue;
            st.points_visited += uint64_t(xh - xl + 1);
            const int64_t row = dims.index(0, y, z) + lo[0];
            for (int64_t xr = int64_t(xl); xr <= int64_t(xh); ++xr) {
                // A point already written got this same value from its other tet.
                if (covered[std::size_t(row + xr)]) continue;
                std::array<I, 4> n;
                for (int i = 0; i < 4; ++i) n[i] = r[i] + g[i][0] * I(xr);
                w.put(row + xr, n, D, f, fi);
                covered[std::size_t(row + xr)] = 1;
            }
        }
}

template <class T>
void rasterise(const TetMesh& mesh, Volume& vol, std::vector<uint8_t>& covered,
               MeshResampleStats& st) {
    const Dims dims = vol.dims;
    bool exact_ints = false;
    if constexpr (std::is_integral_v<T>) {
        exact_ints = true;
        for (double v : mesh.values)
            if (!(std::floor(v) == v) || std::fabs(v) > 9.0e18) {
                exact_ints = false;
                break;
            }
    }
    const Writer<T> w{vol.as<T>(), exact_ints};

    for (const auto& tet : mesh.tets) {  // vertex ids checked by validate() in resample_mesh
        // Canonical vertex order (increasing id): sums are order-independent per face.
        std::array<uint32_t, 4> ids = tet;
        std::sort(ids.begin(), ids.end());
        std::array<std::array<int64_t, 3>, 4> P;
        std::array<int64_t, 3> lo{}, hi{};
        for (int i = 0; i < 4; ++i)
            for (int a = 0; a < 3; ++a) {
                P[i][a] = mesh.points[ids[i]][a];
                lo[a] = i == 0 ? P[i][a] : std::min(lo[a], P[i][a]);
                hi[a] = i == 0 ? P[i][a] : std::max(hi[a], P[i][a]);
            }
        // Skip tets entirely outside the grid.
        if (hi[0] < 0 || hi[1] < 0 || hi[2] < 0 || lo[0] >= dims.x || lo[1] >= dims.y ||
            lo[2] >= dims.z)
            continue;
        for (auto& p : P)
            for (int a = 0; a < 3; ++a) p[a] -= lo[a];
        const i128 D = signed_volume(P);
        if (D == 0) {
            ++st.degenerate_tets;
            continue;
        }
        std::array<double, 4> f{};
        std::array<int64_t, 4> fi{};
        for (int i = 0; i < 4; ++i) {
            f[i] = mesh.values[ids[i]];
            fi[i] = exact_ints ? int64_t(f[i]) : 0;
        }
        constexpr int64_t kSmall = int64_t{1} << 20;
        if (hi[0] - lo[0] <= kSmall && hi[1] - lo[1] <= kSmall && hi[2] - lo[2] <= kSmall)
            scan_tet<int64_t>(P, D, lo, hi, f, fi, w, dims, covered, st);
        else
            scan_tet<i128>(P, D, lo, hi, f, fi, w, dims, covered, st);
    }
}

}  // namespace

Volume resample_mesh(const TetMesh& mesh, const Dims& dims, ValueType type,
                     MeshResampleStats* stats) {
    validate_dims(dims, "resample_mesh");
    validate(mesh, "resample_mesh");
    Volume vol = Volume::allocate(dims, type);
    vol.spacing = mesh.geometry.spacing;
    vol.origin = mesh.geometry.origin;
    vol.field_name = mesh.field_name;
    std::vector<uint8_t> covered(std::size_t(dims.count()), 0);
    MeshResampleStats st;
    st.grid_points = uint64_t(dims.count());
    dispatch_value_type(type, [&](auto tag) { rasterise<decltype(tag)>(mesh, vol, covered, st); });
    for (uint8_t b : covered) st.covered += b;
    if (stats) *stats = st;
    return vol;
}

}  // namespace tetlod
