#include "support/mesh_checker.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

namespace tetlod::test {
namespace {

using I128 = __int128;

struct V3 {
    int64_t x, y, z;
};
V3 sub(const Pt& a, const Pt& b) { return {int64_t{a[0]} - b[0], int64_t{a[1]} - b[1], int64_t{a[2]} - b[2]}; }
V3 cross(const V3& a, const V3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
int64_t dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
int64_t dotp(const V3& a, const Pt& p) { return a.x * p[0] + a.y * p[1] + a.z * p[2]; }

int64_t floor_div(int64_t a, int64_t b) {  // b > 0
    int64_t q = a / b;
    if ((a % b != 0) && (a < 0)) --q;
    return q;
}
int64_t ceil_div(int64_t a, int64_t b) { return -floor_div(-a, b); }

std::string str(const Pt& p) {
    return "(" + std::to_string(p[0]) + "," + std::to_string(p[1]) + "," + std::to_string(p[2]) + ")";
}
std::string str(const TetPts& t) { return "[" + str(t[0]) + " " + str(t[1]) + " " + str(t[2]) + " " + str(t[3]) + "]"; }

/// The four barycentric numerators as affine functions of p: Di(p) = n[i].p + c[i],
/// D0 + D1 + D2 + D3 = D. p is in the closed tet iff s*Di(p) >= 0 for all i (s = sign D).
struct Planes {
    V3 n[4];
    int64_t c[4];
    int64_t D;
    explicit Planes(const TetPts& t) {
        V3 e1 = sub(t[1], t[0]), e2 = sub(t[2], t[0]), e3 = sub(t[3], t[0]);
        n[1] = cross(e2, e3);
        n[2] = cross(e3, e1);
        n[3] = cross(e1, e2);
        D = dot(e1, n[1]);
        for (int i = 1; i < 4; ++i) c[i] = -dotp(n[i], t[0]);
        n[0] = {-(n[1].x + n[2].x + n[3].x), -(n[1].y + n[2].y + n[3].y), -(n[1].z + n[2].z + n[3].z)};
        c[0] = D - c[1] - c[2] - c[3];
    }
};

/// Visits every grid point of the closed tet row by row: f(p, Di[4], D).
template <class F>
void rasterize(const TetPts& t, F&& f) {
    Planes pl(t);
    if (pl.D == 0) return;
    const int64_t s = pl.D > 0 ? 1 : -1;
    Pt lo = t[0], hi = t[0];
    for (int v = 1; v < 4; ++v)
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], t[v][a]);
            hi[a] = std::max(hi[a], t[v][a]);
        }
    Pt p;
    int64_t d[4];
    for (int32_t z = lo[2]; z <= hi[2]; ++z) {
        for (int32_t y = lo[1]; y <= hi[1]; ++y) {
            int64_t xa = lo[0], xb = hi[0];
            int64_t A[4], B[4];
            for (int i = 0; i < 4; ++i) {
                A[i] = s * pl.n[i].x;
                B[i] = s * (pl.n[i].y * y + pl.n[i].z * z + pl.c[i]);
                if (A[i] > 0)
                    xa = std::max(xa, ceil_div(-B[i], A[i]));
                else if (A[i] < 0)
                    xb = std::min(xb, floor_div(B[i], -A[i]));
                else if (B[i] < 0)
                    xb = xa - 1;
            }
            p[1] = y;
            p[2] = z;
            for (int64_t x = xa; x <= xb; ++x) {
                p[0] = static_cast<int32_t>(x);
                for (int i = 0; i < 4; ++i) d[i] = A[i] * x + B[i];  // = s * Di(p) >= 0
                f(p, d, s);
            }
        }
    }
}

/// |f(p) - L_T(p)| from the (sign-normalised) numerators d (d0+..+d3 = |D|).
struct Interp {
    bool integer;
    double err(const double fv[4], double fp, const int64_t d[4]) const {
        const int64_t D = d[0] + d[1] + d[2] + d[3];
        if (integer) {
            I128 num = 0;
            for (int i = 0; i < 4; ++i) num += I128(d[i]) * I128(static_cast<int64_t>(fv[i]));
            I128 diff = I128(static_cast<int64_t>(fp)) * D - num;
            if (diff < 0) diff = -diff;
            return static_cast<double>(static_cast<long double>(diff) / static_cast<long double>(D));
        }
        long double num = 0;
        for (int i = 0; i < 4; ++i) num += static_cast<long double>(d[i]) * fv[i];
        return static_cast<double>(std::fabs(static_cast<long double>(fp) - num / D));
    }
};

}  // namespace

int64_t tet_det(const TetPts& t) {
    V3 e1 = sub(t[1], t[0]), e2 = sub(t[2], t[0]), e3 = sub(t[3], t[0]);
    return dot(e1, cross(e2, e3));
}

TetPts tet_points(const TetMesh& mesh, std::size_t i) {
    const auto& t = mesh.tets[i];
    return {mesh.points[t[0]], mesh.points[t[1]], mesh.points[t[2]], mesh.points[t[3]]};
}

void for_each_tet_point(const TetPts& tet, const std::function<void(const Pt&, bool)>& f) {
    rasterize(tet, [&](const Pt& p, const int64_t* d, int64_t) {
        f(p, d[0] > 0 && d[1] > 0 && d[2] > 0 && d[3] > 0);
    });
}

TetStats exact_tet_stats(const Volume& v, const TetPts& t) {
    TetStats st;
    st.fmin = std::numeric_limits<double>::infinity();
    st.fmax = -st.fmin;
    Interp ip{!is_float(v.type)};
    double fv[4];
    for (int i = 0; i < 4; ++i) fv[i] = v.value(t[i][0], t[i][1], t[i][2]);
    rasterize(t, [&](const Pt& p, const int64_t* d, int64_t) {
        double fp = v.value(p[0], p[1], p[2]);
        st.error = std::max(st.error, ip.err(fv, fp, d));
        st.fmin = std::min(st.fmin, fp);
        st.fmax = std::max(st.fmax, fp);
        ++st.points;
    });
    return st;
}

bool tet_meets_ball(const TetPts& t, const std::array<int64_t, 3>& c, int64_t r) {
    using I = __int128;
    using V = std::array<I, 3>;
    auto vec = [](const Pt& a, const Pt& b) { return V{I(b[0]) - a[0], I(b[1]) - a[1], I(b[2]) - a[2]}; };
    auto to_c = [&](const Pt& a) { return V{I(c[0]) - a[0], I(c[1]) - a[1], I(c[2]) - a[2]}; };
    auto dot = [](const V& a, const V& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    auto cross = [](const V& a, const V& b) {
        return V{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    const I r2 = I(r) * r;
    // a vertex in the ball
    for (const Pt& p : t)
        if (dot(to_c(p), to_c(p)) <= r2) return true;
    // the nearest point inside an edge: 0 < (c-a).d < |d|^2 and the distance
    // |c-a|^2 - ((c-a).d)^2/|d|^2 <= r^2, multiplied out by |d|^2
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
            const V d = vec(t[i], t[j]), w = to_c(t[i]);
            const I dd = dot(d, d), wd = dot(w, d);
            if (wd > 0 && wd < dd && dot(w, w) * dd - wd * wd <= r2 * dd) return true;
        }
    // the centre's projection inside a face, within r of its plane:
    // ((c-a).n)^2 <= r^2 |n|^2
    static constexpr int kFaces[4][4] = {{1, 2, 3, 0}, {0, 2, 3, 1}, {0, 1, 3, 2}, {0, 1, 2, 3}};
    int inner_sides = 0;
    for (const auto& f : kFaces) {
        const Pt &a = t[f[0]], &b = t[f[1]], &e = t[f[2]];
        const V n = cross(vec(a, b), vec(a, e));
        const I side = dot(n, to_c(a)), opposite = dot(n, vec(a, t[f[3]]));
        if ((side >= 0) == (opposite > 0) || side == 0) ++inner_sides;
        bool within = true;
        const Pt* corner[3] = {&a, &b, &e};
        for (int k = 0; k < 3; ++k) {
            const Pt& p = *corner[k];
            const Pt& q = *corner[(k + 1) % 3];
            if (dot(cross(vec(p, q), to_c(p)), n) < 0) within = false;
        }
        if (within && side * side <= r2 * dot(n, n)) return true;
    }
    // the centre inside the tet (on the inner side of every face plane)
    return inner_sides == 4;
}

bool tet_meets_box(const TetPts& t, const Pt& lo, const Pt& hi) {
    // Separating axis theorem for two convex polytopes: box axes, the 4 face normals
    // of the tet, and the cross products of the 6 tet edges with the 3 box axes.
    std::vector<V3> axes = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const int fi[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    for (auto& f : fi) axes.push_back(cross(sub(t[f[1]], t[f[0]]), sub(t[f[2]], t[f[0]])));
    const V3 unit[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
            for (auto& u : unit) axes.push_back(cross(sub(t[b], t[a]), u));
    for (const V3& ax : axes) {
        if (ax.x == 0 && ax.y == 0 && ax.z == 0) continue;
        int64_t tmin = std::numeric_limits<int64_t>::max(), tmax = std::numeric_limits<int64_t>::min();
        for (auto& p : t) {
            int64_t v = dotp(ax, p);
            tmin = std::min(tmin, v);
            tmax = std::max(tmax, v);
        }
        // box extremes along ax
        int64_t bmin = 0, bmax = 0;
        const int64_t c[3] = {ax.x, ax.y, ax.z};
        for (int k = 0; k < 3; ++k) {
            int64_t a = c[k] * lo[k], b = c[k] * hi[k];
            bmin += std::min(a, b);
            bmax += std::max(a, b);
        }
        if (tmax < bmin || bmax < tmin) return false;
    }
    return true;
}

std::string CheckReport::summary() const {
    std::ostringstream o;
    o << "tets=" << tets << " vertices=" << vertices << " boundary_faces=" << boundary_faces
      << " interior_faces=" << interior_faces << " points_checked=" << points_checked
      << " max_error=" << max_error << " failures=" << failures;
    for (auto& m : messages) o << "\n  - " << m;
    if (failures > static_cast<int64_t>(messages.size())) o << "\n  ... and " << failures - messages.size() << " more";
    return o.str();
}

void CheckReport::fail(const std::string& msg, int max_messages) {
    ++failures;
    if (static_cast<int>(messages.size()) < max_messages) messages.push_back(msg);
}

double float_tolerance(const Volume& v) {
    if (!is_float(v.type)) return 0.0;
    auto r = v.range();
    return 1e-9 * std::max(1.0, r[1] - r[0]);
}

CheckReport check_mesh(const Volume& vol, const TetMesh& mesh, const CheckOptions& opt) {
    CheckReport rep;
    auto fail = [&](const std::string& m) { rep.fail(m, opt.max_messages); };
    const Pt bmax = {static_cast<int32_t>(vol.dims.x - 1), static_cast<int32_t>(vol.dims.y - 1),
                     static_cast<int32_t>(vol.dims.z - 1)};
    const int64_t nv = static_cast<int64_t>(mesh.points.size());
    rep.tets = static_cast<int64_t>(mesh.tets.size());
    rep.vertices = nv;
    auto in_box = [&](const Pt& p) {
        for (int a = 0; a < 3; ++a)
            if (p[a] < 0 || p[a] > bmax[a]) return false;
        return true;
    };
    auto lin = [&](const Pt& p) { return vol.dims.index(p[0], p[1], p[2]); };

    // ---- vertices: in box, exact values, no duplicates; point -> vertex id map
    std::vector<int32_t> vid(static_cast<std::size_t>(vol.count()), -1);
    std::vector<char> vertex_ok(static_cast<std::size_t>(nv), 1);
    if (mesh.values.size() != mesh.points.size())
        fail("values.size()=" + std::to_string(mesh.values.size()) + " != points.size()=" + std::to_string(nv));
    for (int64_t i = 0; i < nv; ++i) {
        const Pt& p = mesh.points[i];
        if (!in_box(p)) {
            if (opt.validity) fail("vertex " + std::to_string(i) + " " + str(p) + " outside the data box");
            vertex_ok[i] = 0;
            continue;
        }
        int32_t& slot = vid[lin(p)];
        if (slot >= 0) {
            if (opt.validity)
                fail("duplicate vertex coordinates " + str(p) + ": ids " + std::to_string(slot) + " and " +
                     std::to_string(i));
        } else {
            slot = static_cast<int32_t>(i);
        }
        if (opt.validity && i < static_cast<int64_t>(mesh.values.size())) {
            double f = vol.value(lin(p));
            if (!(mesh.values[i] == f) && !(std::isnan(f) && std::isnan(mesh.values[i])))
                fail("vertex " + std::to_string(i) + " " + str(p) + " value " + std::to_string(mesh.values[i]) +
                     " != volume " + std::to_string(f));
        }
    }

    // ---- tets: ids, orientation, volume sum
    std::vector<char> tet_ok(mesh.tets.size(), 1);
    I128 vol6 = 0;
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
        const auto& tt = mesh.tets[t];
        bool ok = true;
        for (int a = 0; a < 4; ++a) {
            if (tt[a] >= static_cast<uint64_t>(nv) || !vertex_ok[tt[a]]) ok = false;
            for (int b = a + 1; b < 4; ++b)
                if (tt[a] == tt[b]) ok = false;
        }
        if (!ok) {
            fail("tet " + std::to_string(t) + " has bad/repeated/out-of-box vertex ids");
            tet_ok[t] = 0;
            continue;
        }
        int64_t det = tet_det(tet_points(mesh, t));
        vol6 += det < 0 ? -det : det;
        if (det <= 0) {
            if (opt.validity || det == 0)
                fail("tet " + std::to_string(t) + " " + str(tet_points(mesh, t)) + " orientation det=" +
                     std::to_string(det) + " (must be > 0)");
            if (det == 0) tet_ok[t] = 0;
        }
    }
    if (opt.volume_sum) {
        I128 expect = I128(6) * bmax[0] * bmax[1] * bmax[2];
        if (vol6 != expect)
            fail("sum of 6*volume = " + std::to_string(static_cast<long long>(vol6)) + " != 6*box volume " +
                 std::to_string(static_cast<long long>(expect)));
    }

    // ---- faces
    if (opt.conformity) {
        struct Face {
            std::array<uint32_t, 3> k;
            uint32_t tet;
            uint32_t opp;
        };
        std::vector<Face> faces;
        faces.reserve(mesh.tets.size() * 4);
        for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
            if (!tet_ok[t]) continue;
            const auto& tt = mesh.tets[t];
            for (int o = 0; o < 4; ++o) {
                std::array<uint32_t, 3> k;
                int j = 0;
                for (int a = 0; a < 4; ++a)
                    if (a != o) k[j++] = tt[a];
                std::sort(k.begin(), k.end());
                faces.push_back({k, static_cast<uint32_t>(t), tt[o]});
            }
        }
        std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.k < b.k; });
        for (std::size_t i = 0; i < faces.size();) {
            std::size_t j = i;
            while (j < faces.size() && faces[j].k == faces[i].k) ++j;
            const auto& k = faces[i].k;
            TetPts fp = {mesh.points[k[0]], mesh.points[k[1]], mesh.points[k[2]], Pt{}};
            bool on_boundary = false;
            for (int a = 0; a < 3; ++a)
                for (int32_t plane : {0, bmax[a]})
                    if (fp[0][a] == plane && fp[1][a] == plane && fp[2][a] == plane) on_boundary = true;
            std::string fs = "face " + str(fp[0]) + " " + str(fp[1]) + " " + str(fp[2]);
            if (j - i == 1) {
                ++rep.boundary_faces;
                if (!on_boundary)
                    fail(fs + " of tet " + std::to_string(faces[i].tet) +
                         " is used by one tet but is not on the box boundary (crack / T-junction)");
            } else if (j - i == 2) {
                ++rep.interior_faces;
                if (on_boundary) fail(fs + " lies on the box boundary but is used by two tets");
                fp[3] = mesh.points[faces[i].opp];
                int64_t s1 = tet_det(fp);
                fp[3] = mesh.points[faces[i + 1].opp];
                int64_t s2 = tet_det(fp);
                if (!((s1 > 0 && s2 < 0) || (s1 < 0 && s2 > 0)))
                    fail(fs + " shared by tets " + std::to_string(faces[i].tet) + " and " +
                         std::to_string(faces[i + 1].tet) + " on the same side (overlap)");
            } else {
                fail(fs + " is used by " + std::to_string(j - i) + " tets");
            }
            i = j;
        }
    }

    // ---- per-point pass: coverage, hanging vertices / overlaps, the error bound
    const bool bound = static_cast<bool>(opt.allowed);
    if (bound || opt.coverage || opt.conformity) {
        std::vector<uint8_t> cover(static_cast<std::size_t>(vol.count()), 0);
        std::vector<uint8_t> interior(static_cast<std::size_t>(vol.count()), 0);
        std::vector<double> fval(static_cast<std::size_t>(vol.count()));
        for (int64_t i = 0; i < vol.count(); ++i) fval[i] = vol.value(i);
        Interp ip{!is_float(vol.type)};
        for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
            if (!tet_ok[t]) continue;
            const TetPts tp = tet_points(mesh, t);
            const auto& ids = mesh.tets[t];
            const double allowed = bound ? opt.allowed(tp) + opt.tolerance : 0.0;
            double fv[4];
            for (int i = 0; i < 4; ++i) fv[i] = fval[lin(tp[i])];
            double worst = -1.0;
            Pt worst_p{};
            rasterize(tp, [&](const Pt& p, const int64_t* d, int64_t) {
                if (!in_box(p)) return;  // impossible: vertices are in the box
                const int64_t li = lin(p);
                if (cover[li] < 255) ++cover[li];
                if (d[0] > 0 && d[1] > 0 && d[2] > 0 && d[3] > 0) interior[li] = 1;
                if (opt.conformity) {
                    int32_t v = vid[li];
                    if (v >= 0 && static_cast<uint32_t>(v) != ids[0] && static_cast<uint32_t>(v) != ids[1] &&
                        static_cast<uint32_t>(v) != ids[2] && static_cast<uint32_t>(v) != ids[3])
                        fail("mesh vertex " + std::to_string(v) + " " + str(p) + " lies in tet " +
                             std::to_string(t) + " " + str(tp) + " but is not one of its corners (hanging vertex or overlap)");
                }
                if (bound) {
                    ++rep.points_checked;
                    double e = ip.err(fv, fval[li], d);
                    if (e > worst) {
                        worst = e;
                        worst_p = p;
                    }
                }
            });
            if (bound) {
                rep.max_error = std::max(rep.max_error, worst);
                if (!(worst <= allowed))
                    fail("bound: tet " + std::to_string(t) + " " + str(tp) + " has |f - L_T| = " +
                         std::to_string(worst) + " at " + str(worst_p) + " > allowed " +
                         std::to_string(allowed - opt.tolerance));
            }
        }
        if (opt.coverage || opt.conformity) {
            for (int32_t z = 0; z <= bmax[2]; ++z)
                for (int32_t y = 0; y <= bmax[1]; ++y)
                    for (int32_t x = 0; x <= bmax[0]; ++x) {
                        int64_t li = vol.dims.index(x, y, z);
                        if (opt.coverage && cover[li] == 0) fail("grid point " + str(Pt{x, y, z}) + " is covered by no tet");
                        if (opt.conformity && interior[li] && cover[li] > 1)
                            fail("grid point " + str(Pt{x, y, z}) + " is strictly inside one tet and touched by " +
                                 std::to_string(cover[li] - 1) + " other(s) (overlap)");
                    }
        }
    }
    return rep;
}

::testing::AssertionResult mesh_ok(const Volume& volume, const TetMesh& mesh, const CheckOptions& options) {
    CheckReport r = check_mesh(volume, mesh, options);
    if (r.ok()) return ::testing::AssertionSuccess() << r.summary();
    return ::testing::AssertionFailure() << r.summary();
}

}  // namespace tetlod::test
