// Marching tetrahedra (Doi and Koide, "An efficient method of triangulating
// equi-valued surfaces by using tetrahedral cells", IEICE 1991) on an extracted
// TetMesh. Conventions are in isosurface.hpp; the orientation is derived
// combinatorially from the tet's positive orientation, never from the computed
// positions, so it stays consistent when samples equal the isovalue and surface
// vertices coincide.
#include "tetlod/models/isosurface.hpp"

#include <cmath>
#include <string>
#include <unordered_map>

#include "surface_weld.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"

namespace tetlod {

namespace {

using P3 = std::array<double, 3>;

P3 sub(const P3& a, const P3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
P3 cross(const P3& a, const P3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const P3& a, const P3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Face opposite vertex i of a positively oriented tet, ordered so its normal
// points away from i (out of the tet).
constexpr int kOppositeFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

struct Surfacer {
    const TetMesh& mesh;
    TriangleMesh& out;
    IsosurfaceStats& stats;
    std::vector<P3> world;                     // per mesh vertex
    std::vector<double> grad_weight;           // per surface vertex
    std::vector<uint16_t> vertex_surface;      // per surface vertex
    std::unordered_map<uint64_t, uint32_t> edge_vertex;  // per isovalue
    std::unordered_map<uint32_t, uint32_t> sample_vertex;  // per isovalue: samples equal to it
    uint16_t current_surface = 0;              // the isovalue being cut

    uint32_t new_vertex(const P3& p) {
        out.points.push_back(p);
        out.gradients.push_back({0, 0, 0});
        grad_weight.push_back(0);
        vertex_surface.push_back(current_surface);
        return uint32_t(out.points.size() - 1);
    }

    // Surface vertex on edge (a, b) for isovalue v; a and b straddle v.
    uint32_t vertex_on(uint32_t a, uint32_t b, double v) {
        uint32_t o = a, i = b;
        if (mesh.values[a] >= v) std::swap(o, i);
        const double fo = mesh.values[o], fi = mesh.values[i];
        // The inside end equals v: the vertex is that sample itself, shared by
        // all its crossed edges (no interpolation, so bit-exactly the sample).
        if (fi == v) {
            auto [it, fresh] = sample_vertex.try_emplace(i, 0u);
            if (fresh) it->second = new_vertex(world[i]);
            return it->second;
        }
        const uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
        auto [it, fresh] = edge_vertex.try_emplace(key, 0u);
        if (fresh) {
            // Interpolate from the outside end (f < v) to the inside end (f >= v):
            // t in (0, 1), computed the same way whichever tet asks first.
            const double t = (v - fo) / (fi - fo);
            const P3& po = world[o];
            const P3& pi = world[i];
            it->second = new_vertex({po[0] + t * (pi[0] - po[0]), po[1] + t * (pi[1] - po[1]),
                                     po[2] + t * (pi[2] - po[2])});
        }
        return it->second;
    }

    void add_face(uint32_t a, uint32_t b, uint32_t c, float err, uint16_t surface_id) {
        out.faces.push_back({a, b, c});
        out.face_error.push_back(err);
        out.face_surface.push_back(surface_id);
    }

    void accumulate(uint32_t s, const P3& g, double w) {
        for (int k = 0; k < 3; ++k) out.gradients[s][k] += g[k] * w;
        grad_weight[s] += w;
    }

    void tet(std::size_t ti, double v, uint16_t surface) {
        const auto& t = mesh.tets[ti];
        int inside[4], outside[4], ni = 0, no = 0;
        for (int k = 0; k < 4; ++k) {
            if (mesh.values[t[k]] >= v)
                inside[ni++] = k;
            else
                outside[no++] = k;
        }
        if (ni == 0 || ni == 4) return;
        ++stats.crossed_tets;
        const float err = mesh.error.empty() ? 0.0f : mesh.error[ti];

        // Constant gradient of the linear interpolant (world units) and the tet's
        // volume, for the vertex gradients.
        const P3 e1 = sub(world[t[1]], world[t[0]]), e2 = sub(world[t[2]], world[t[0]]),
                 e3 = sub(world[t[3]], world[t[0]]);
        const double det = dot(e1, cross(e2, e3));
        P3 g{0, 0, 0};
        if (det != 0.0) {
            const double d1 = mesh.values[t[1]] - mesh.values[t[0]];
            const double d2 = mesh.values[t[2]] - mesh.values[t[0]];
            const double d3 = mesh.values[t[3]] - mesh.values[t[0]];
            const P3 c23 = cross(e2, e3), c31 = cross(e3, e1), c12 = cross(e1, e2);
            for (int k = 0; k < 3; ++k) g[k] = (d1 * c23[k] + d2 * c31[k] + d3 * c12[k]) / det;
        }
        const double w = std::abs(det) / 6.0;

        uint32_t s[4];
        int ns = 0;
        if (ni == 1 || ni == 3) {
            // One vertex alone on its side: a triangle around it, on its three edges.
            const bool lone_inside = ni == 1;
            const int lone = lone_inside ? inside[0] : outside[0];
            const int* f = kOppositeFace[lone];
            for (int k = 0; k < 3; ++k) s[k] = vertex_on(t[lone], t[f[k]], v);
            ns = 3;
            // (f0, f1, f2) faces away from `lone`: right when lone is inside.
            if (lone_inside)
                add_face(s[0], s[1], s[2], err, surface);
            else
                add_face(s[0], s[2], s[1], err, surface);
        } else {
            // Two and two: a quadrilateral. Order (a, b, c, d) as a positive
            // permutation of the tet with a, b inside; then the cycle
            // ac -> ad -> bd -> bc faces towards c, d (outside).
            int a = inside[0], b = inside[1], c = outside[0], d = outside[1];
            // Parity of the permutation (a, b, c, d) of (0, 1, 2, 3).
            const int perm[4] = {a, b, c, d};
            int inversions = 0;
            for (int x = 0; x < 4; ++x)
                for (int y = x + 1; y < 4; ++y) inversions += perm[x] > perm[y];
            if (inversions & 1) std::swap(c, d);
            const uint32_t ac = vertex_on(t[a], t[c], v), ad = vertex_on(t[a], t[d], v),
                           bd = vertex_on(t[b], t[d], v), bc = vertex_on(t[b], t[c], v);
            s[0] = ac, s[1] = ad, s[2] = bd, s[3] = bc;
            ns = 4;
            // Split along the shorter diagonal (better triangles); either keeps
            // the surface closed because the diagonal is interior to the tet.
            const P3 d02 = sub(out.points[bd], out.points[ac]);
            const P3 d13 = sub(out.points[bc], out.points[ad]);
            if (dot(d02, d02) <= dot(d13, d13)) {
                add_face(ac, ad, bd, err, surface);
                add_face(ac, bd, bc, err, surface);
            } else {
                add_face(ac, ad, bc, err, surface);
                add_face(ad, bd, bc, err, surface);
            }
        }
        for (int k = 0; k < ns; ++k) accumulate(s[k], g, w);
    }
};

}  // namespace

TriangleMesh marching_tetrahedra(const TetMesh& mesh, std::span<const double> isovalues,
                                 IsosurfaceStats* stats_out) {
    validate(mesh, "isosurface");
    if (isovalues.size() > 65535)
        throw Error(ErrorCode::InvalidArgument, "isosurface: more than 65535 isovalues");
    for (double v : isovalues)
        if (std::isnan(v)) throw Error(ErrorCode::InvalidArgument, "isosurface: isovalue is NaN");

    TriangleMesh out;
    IsosurfaceStats stats;
    Surfacer s{mesh, out, stats, {}, {}, {}, {}, {}};
    s.world.reserve(mesh.points.size());
    for (const auto& p : mesh.points) s.world.push_back(mesh.geometry.world(p));
    for (std::size_t i = 0; i < isovalues.size(); ++i) {
        s.edge_vertex.clear();
        s.sample_vertex.clear();
        s.current_surface = static_cast<uint16_t>(i);
        for (std::size_t t = 0; t < mesh.tets.size(); ++t)
            s.tet(t, isovalues[i], static_cast<uint16_t>(i));
    }

    detail::weld_surface({out, s.grad_weight, s.vertex_surface}, stats);
    for (const auto& f : out.faces) {
        const P3 n = cross(sub(out.points[f[1]], out.points[f[0]]),
                           sub(out.points[f[2]], out.points[f[0]]));
        if (dot(n, n) == 0.0) ++stats.zero_area_faces;
    }

    // Vertex gradients: weighted means; normals point down the gradient. A
    // vertex whose tets are all flat (never on a positive mesh) falls back to
    // the area-weighted normal of its faces.
    out.normals.assign(out.points.size(), {0, 0, 0});
    std::vector<P3> face_sum(out.points.size(), P3{0, 0, 0});
    for (const auto& f : out.faces) {
        const P3 n = cross(sub(out.points[f[1]], out.points[f[0]]),
                           sub(out.points[f[2]], out.points[f[0]]));
        for (uint32_t v : f)
            for (int k = 0; k < 3; ++k) face_sum[v][k] += n[k];
    }
    for (std::size_t v = 0; v < out.points.size(); ++v) {
        auto& g = out.gradients[v];
        if (s.grad_weight[v] > 0)
            for (int k = 0; k < 3; ++k) g[k] /= s.grad_weight[v];
        P3 n{-g[0], -g[1], -g[2]};
        double len = std::sqrt(dot(n, n));
        if (!(len > 0) || !std::isfinite(len)) {
            n = face_sum[v];
            len = std::sqrt(dot(n, n));
        }
        if (len > 0 && std::isfinite(len)) out.normals[v] = {n[0] / len, n[1] / len, n[2] / len};
    }
    if (stats_out) *stats_out = stats;
    return out;
}

double enclosed_volume(const TriangleMesh& s) {
    double v = 0;
    for (const auto& f : s.faces)
        v += dot(s.points[f[0]], cross(s.points[f[1]], s.points[f[2]]));
    return v / 6.0;
}

}  // namespace tetlod
