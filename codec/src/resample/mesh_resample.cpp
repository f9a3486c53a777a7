// Rasterisation of a TetMesh onto the grid (see mesh_resample.hpp).
#include "tetlod/codec/mesh_resample.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "tetlod/core/error.hpp"

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
i128 floor_div(i128 a, i128 b) {
    i128 q = a / b;
    if (a % b != 0 && a < 0) --q;
    return q;
}
// ceil(a / b), b > 0.
i128 ceil_div(i128 a, i128 b) { return -floor_div(-a, b); }

template <class T>
struct Writer {
    T* out;
    bool exact_ints;  // integer type and integer vertex values: the rational path

    void put(int64_t idx, const std::array<i128, 4>& n, i128 d, const std::array<double, 4>& f,
             const std::array<int64_t, 4>& fi) const {
        if constexpr (std::is_integral_v<T>) {
            if (exact_ints) {
                i128 num = 0;
                for (int i = 0; i < 4; ++i) num += n[i] * fi[i];
                // round(num / d), ties towards +inf: floor((2 num + d) / (2 d)).
                i128 r = floor_div(2 * num + d, 2 * d);
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
    const int64_t nv = int64_t(mesh.points.size());

    for (const auto& tet : mesh.tets) {
        // Canonical vertex order (increasing id): sums are order-independent per face.
        std::array<uint32_t, 4> ids = tet;
        for (uint32_t id : ids)
            if (int64_t(id) >= nv)
                throw Error(ErrorCode::InvalidArgument,
                            "resample_mesh: vertex id " + std::to_string(id) + " out of range");
        std::sort(ids.begin(), ids.end());
        std::array<std::array<int64_t, 3>, 4> P;
        std::array<int64_t, 3> lo{}, hi{};
        for (int i = 0; i < 4; ++i)
            for (int a = 0; a < 3; ++a) {
                P[i][a] = mesh.points[ids[i]][a];
                lo[a] = i == 0 ? P[i][a] : std::min(lo[a], P[i][a]);
                hi[a] = i == 0 ? P[i][a] : std::max(hi[a], P[i][a]);
            }
        i128 D = signed_volume(P);
        if (D == 0) {
            ++st.degenerate_tets;
            continue;
        }
        // Coordinates relative to the bounding box's low corner.
        for (auto& p : P)
            for (int a = 0; a < 3; ++a) p[a] -= lo[a];
        // N_i(p) = c[i] + g[i] . p, affine: evaluate at 0 and the unit vectors.
        std::array<i128, 4> c{};
        std::array<std::array<i128, 3>, 4> g{};
        for (int i = 0; i < 4; ++i) {
            auto Q = P;
            Q[i] = {0, 0, 0};
            c[i] = signed_volume(Q);
            for (int a = 0; a < 3; ++a) {
                Q[i] = {0, 0, 0};
                Q[i][a] = 1;
                g[i][a] = signed_volume(Q) - c[i];
            }
        }
        if (D < 0) {
            D = -D;
            for (int i = 0; i < 4; ++i) {
                c[i] = -c[i];
                for (int a = 0; a < 3; ++a) g[i][a] = -g[i][a];
            }
        }
        std::array<double, 4> f{};
        std::array<int64_t, 4> fi{};
        for (int i = 0; i < 4; ++i) {
            f[i] = mesh.values[ids[i]];
            fi[i] = exact_ints ? int64_t(f[i]) : 0;
        }
        // Clip the bounding box to the grid.
        const int64_t z0 = std::max<int64_t>(lo[2], 0), z1 = std::min<int64_t>(hi[2], dims.z - 1);
        const int64_t y0 = std::max<int64_t>(lo[1], 0), y1 = std::min<int64_t>(hi[1], dims.y - 1);
        const int64_t xa = std::max<int64_t>(lo[0], 0), xb = std::min<int64_t>(hi[0], dims.x - 1);
        if (xa > xb) continue;
        for (int64_t z = z0; z <= z1; ++z)
            for (int64_t y = y0; y <= y1; ++y) {
                std::array<i128, 4> r;
                i128 xl = xa - lo[0], xh = xb - lo[0];  // relative x interval
                for (int i = 0; i < 4; ++i) {
                    r[i] = c[i] + g[i][1] * (y - lo[1]) + g[i][2] * (z - lo[2]);
                    const i128 gx = g[i][0];
                    if (gx > 0)
                        xl = std::max(xl, ceil_div(-r[i], gx));
                    else if (gx < 0)
                        xh = std::min(xh, floor_div(r[i], -gx));
                    else if (r[i] < 0)
                        xh = xl - 1;
                }
                if (xl > xh) continue;
                const int64_t row = dims.index(0, y, z);
                for (int64_t xr = int64_t(xl); xr <= int64_t(xh); ++xr) {
                    std::array<i128, 4> n;
                    for (int i = 0; i < 4; ++i) n[i] = r[i] + g[i][0] * xr;
                    const int64_t idx = row + lo[0] + xr;
                    w.put(idx, n, D, f, fi);
                    covered[std::size_t(idx)] = 1;
                }
            }
    }
}

}  // namespace

Volume resample_mesh(const TetMesh& mesh, const Dims& dims, ValueType type,
                     MeshResampleStats* stats) {
    validate_dims(dims, "resample_mesh");
    if (mesh.values.size() != mesh.points.size())
        throw Error(ErrorCode::InvalidArgument, "resample_mesh: " +
                                                    std::to_string(mesh.values.size()) +
                                                    " values for " +
                                                    std::to_string(mesh.points.size()) + " vertices");
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
