// Marching tetrahedra on analytic fields, checked against geometry and topology
// computed here from the faces alone (edge use counts, Euler characteristic,
// enclosed volume, distances to the exact surface), never by re-running the
// extractor's own logic.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <vector>

#include "surface_test_util.hpp"
#include "tetlod/models/isosurface.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {
namespace {

using test::ball_volume;
using test::full_mesh;

struct Topology {
    std::size_t faces = 0, vertices = 0, edges = 0;
    std::size_t boundary_edges = 0;      // used by one face
    std::size_t nonmanifold_edges = 0;   // used by more than two faces
    std::size_t misoriented_edges = 0;   // used twice in the same direction
    long euler() const { return long(vertices) - long(edges) + long(faces); }
};

// Topology of the faces of surface `which` (-1: all).
Topology topology(const TriangleMesh& s, int which = -1) {
    Topology t;
    std::map<std::pair<uint32_t, uint32_t>, int> directed;
    std::set<uint32_t> used;
    for (std::size_t i = 0; i < s.faces.size(); ++i) {
        if (which >= 0 && s.face_surface[i] != which) continue;
        const auto& f = s.faces[i];
        ++t.faces;
        for (int k = 0; k < 3; ++k) {
            used.insert(f[k]);
            ++directed[{f[k], f[(k + 1) % 3]}];
        }
    }
    std::map<std::pair<uint32_t, uint32_t>, int> undirected;
    for (const auto& [e, n] : directed) {
        if (n > 1) ++t.misoriented_edges;
        undirected[{std::min(e.first, e.second), std::max(e.first, e.second)}] += n;
    }
    for (const auto& [e, n] : undirected) {
        if (n == 1) ++t.boundary_edges;
        if (n > 2) ++t.nonmanifold_edges;
        // An interior edge must be used once in each direction.
        if (n == 2 && !(directed.count(e) && directed.count({e.second, e.first})))
            ++t.misoriented_edges;
    }
    t.edges = undirected.size();
    t.vertices = used.size();
    return t;
}

void expect_closed_sphere(const Topology& t) {
    EXPECT_GT(t.faces, 0u);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.nonmanifold_edges, 0u);
    EXPECT_EQ(t.misoriented_edges, 0u);
    EXPECT_EQ(t.euler(), 2);
    EXPECT_EQ(3 * t.faces, 2 * t.edges);  // every edge in exactly two faces
}

double volume_of(const TriangleMesh& s, int which) {
    TriangleMesh part = s;
    part.faces.clear();
    for (std::size_t i = 0; i < s.faces.size(); ++i)
        if (s.face_surface[i] == which) part.faces.push_back(s.faces[i]);
    return enclosed_volume(part);
}

TEST(Isosurface, SphereOnFullMeshIsClosedOrientedAndRound) {
    const double r = 11.3;
    const std::array<double, 3> c{16.2, 15.9, 16.1};
    TetMesh mesh = full_mesh(ball_volume(33, c, r));
    const double iso[] = {0.0};
    IsosurfaceStats stats;
    const TriangleMesh s = marching_tetrahedra(mesh, iso, &stats);
    expect_closed_sphere(topology(s));
    EXPECT_GT(stats.crossed_tets, 0u);
    const double exact = 4.0 / 3.0 * std::numbers::pi * r * r * r;
    EXPECT_NEAR(enclosed_volume(s), exact, 0.01 * exact);
    ASSERT_EQ(s.normals.size(), s.points.size());
    ASSERT_EQ(s.gradients.size(), s.points.size());
    ASSERT_EQ(s.face_error.size(), s.faces.size());
    for (std::size_t v = 0; v < s.points.size(); ++v) {
        const auto& p = s.points[v];
        const std::array<double, 3> d{p[0] - c[0], p[1] - c[1], p[2] - c[2]};
        const double dist = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        EXPECT_NEAR(dist, r, 0.5);
        // Inside is f >= 0 = the ball; normals point out of it (decreasing f).
        const auto& n = s.normals[v];
        EXPECT_GT((n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / dist, 0.9);
        EXPECT_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0, 1e-9);
        // Gradient of r^2 - |p-c|^2 is -2 (p - c): normal = -gradient direction.
        const auto& g = s.gradients[v];
        EXPECT_LT(g[0] * d[0] + g[1] * d[1] + g[2] * d[2], 0.0);
    }
}

TEST(Isosurface, WorldCoordinatesFollowGeometry) {
    TetMesh mesh = full_mesh(ball_volume(17, {8, 8, 8}, 5.5));
    const double iso[] = {0.0};
    const double v1 = enclosed_volume(marching_tetrahedra(mesh, iso));
    mesh.geometry.spacing = {2.0, 0.5, 1.5};
    mesh.geometry.origin = {-3, 4, 10};
    const TriangleMesh s = marching_tetrahedra(mesh, iso);
    EXPECT_NEAR(enclosed_volume(s), v1 * 1.5, 1e-9 * v1);  // stays positive: outward
    for (const auto& p : s.points) {
        EXPECT_GE(p[0], -3.0);
        EXPECT_LE(p[0], -3.0 + 2.0 * 16);
        EXPECT_GE(p[1], 4.0);
    }
}

TEST(Isosurface, AdaptiveIsovalueQueryGivesClosedSurface) {
    const double r = 9.7;
    const HtModel model = HtModel::build(ball_volume(33, {15.5, 16.3, 17.1}, r));
    for (double err : {0.0, 2.0, 10.0}) {
        LodQuery q;
        q.error_in = err;
        q.isovalues = {0.0};
        const TetMesh mesh = model.extract(q);
        const double iso[] = {0.0};
        const TriangleMesh s = marching_tetrahedra(mesh, iso);
        SCOPED_TRACE("error " + std::to_string(err));
        expect_closed_sphere(topology(s));
        const double exact = 4.0 / 3.0 * std::numbers::pi * r * r * r;
        EXPECT_NEAR(enclosed_volume(s), exact, (err == 0 ? 0.01 : 0.1) * exact);
    }
}

TEST(Isosurface, SeveralIsovaluesGiveNestedClosedSpheres) {
    const std::array<double, 3> c{16.4, 16.1, 15.8};
    TetMesh mesh = full_mesh(ball_volume(33, c, 14.0));
    // f = 196 - d^2: spheres of radius sqrt(196 - v).
    const double iso[] = {196.0 - 6.1 * 6.1, 196.0 - 12.2 * 12.2};
    const TriangleMesh s = marching_tetrahedra(mesh, iso);
    ASSERT_EQ(s.face_surface.size(), s.faces.size());
    std::size_t total = 0;
    for (int i = 0; i < 2; ++i) {
        SCOPED_TRACE("surface " + std::to_string(i));
        const Topology t = topology(s, i);
        expect_closed_sphere(t);
        total += t.faces;
        const double r = i == 0 ? 6.1 : 12.2;
        const double exact = 4.0 / 3.0 * std::numbers::pi * r * r * r;
        // Linear interpolation of a concave field cuts inside the sphere: the
        // deficit grows like 1/r^2 (2% at r = 6).
        EXPECT_NEAR(volume_of(s, i), exact, 0.03 * exact);
    }
    EXPECT_EQ(total, s.faces.size());
    EXPECT_EQ(topology(s).euler(), 4);
}

// What welding guarantees where samples equal the isovalue, checked from the
// faces alone: no face uses a vertex twice or has zero area, no two vertices of
// one surface share a position, every vertex is one fan of faces (a manifold
// vertex), and the directed edges still balance (closed and consistently
// oriented).
void expect_welded(const TriangleMesh& s) {
    std::map<std::pair<std::array<double, 3>, int>, uint32_t> at;
    std::vector<int> surface_of(s.points.size(), -1);
    for (std::size_t i = 0; i < s.faces.size(); ++i)
        for (uint32_t v : s.faces[i]) surface_of[v] = s.face_surface[i];
    for (uint32_t v = 0; v < s.points.size(); ++v) {
        EXPECT_GE(surface_of[v], 0) << "unused vertex " << v;
        auto [it, fresh] = at.try_emplace({s.points[v], surface_of[v]}, v);
        EXPECT_TRUE(fresh) << "vertices " << it->second << " and " << v << " coincide";
    }
    std::vector<std::vector<std::size_t>> around(s.points.size());
    for (std::size_t i = 0; i < s.faces.size(); ++i) {
        const auto& f = s.faces[i];
        ASSERT_TRUE(f[0] != f[1] && f[1] != f[2] && f[0] != f[2]) << "face " << i;
        const auto &a = s.points[f[0]], &b = s.points[f[1]], &c = s.points[f[2]];
        const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
        const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
        const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
        EXPECT_GT(nx * nx + ny * ny + nz * nz, 0.0) << "zero-area face " << i;
        for (uint32_t v : f) around[v].push_back(i);
    }
    // One fan: the faces around v, joined through shared edges (v, w), form
    // one group (flood fill from the first face).
    for (uint32_t v = 0; v < s.points.size(); ++v) {
        const auto& fs = around[v];
        if (fs.empty()) continue;
        std::vector<char> seen(fs.size(), 0);
        std::vector<std::size_t> stack{0};
        seen[0] = 1;
        std::size_t reached = 1;
        while (!stack.empty()) {
            const std::size_t k = stack.back();
            stack.pop_back();
            for (std::size_t j = 0; j < fs.size(); ++j) {
                if (seen[j]) continue;
                int shared = 0;
                for (uint32_t x : s.faces[fs[k]])
                    for (uint32_t y : s.faces[fs[j]]) shared += x == y;
                if (shared >= 2) seen[j] = 1, ++reached, stack.push_back(j);
            }
        }
        EXPECT_EQ(reached, fs.size()) << "vertex " << v << " is where several fans touch";
    }
    const Topology t = topology(s);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.nonmanifold_edges, 0u);
    EXPECT_EQ(t.misoriented_edges, 0u);
}

TEST(Isosurface, SamplesEqualToTheIsovalueAreWeldedAndZeroAreaFacesDropped) {
    // Integer field with large plateaus exactly at the isovalue: the vertices
    // of all crossed edges at a sample equal to V are that sample, welded into
    // one; faces left with zero area are dropped; the surface stays closed,
    // oriented and manifold.
    Volume v = Volume::allocate(Dims{25, 25, 25}, ValueType::U8);
    for (int z = 0; z < 25; ++z)
        for (int y = 0; y < 25; ++y)
            for (int x = 0; x < 25; ++x) {
                const double d = std::sqrt((x - 12.0) * (x - 12.0) + (y - 12.0) * (y - 12.0) +
                                           (z - 12.0) * (z - 12.0));
                v.set_value(v.dims.index(x, y, z), std::clamp(std::round(20 - d), 0.0, 255.0));
            }
    const TetMesh mesh = full_mesh(std::move(v));
    for (double iso_v : {10.0, 12.0, 15.0}) {
        SCOPED_TRACE("isovalue " + std::to_string(iso_v));
        const double iso[] = {iso_v};
        IsosurfaceStats stats;
        const TriangleMesh s = marching_tetrahedra(mesh, iso, &stats);
        expect_welded(s);
        EXPECT_EQ(topology(s).euler(), 2);
        EXPECT_GT(enclosed_volume(s), 0.0);
        EXPECT_GT(stats.degenerate_faces, 0u);  // the ties really happen
        EXPECT_EQ(stats.zero_area_faces, 0u);
        EXPECT_EQ(stats.nonmanifold_edges, 0u);
    }
}

TEST(Isosurface, SurfaceTouchingItselfAtASampleIsSplitThere) {
    // A column of three samples, the middle one equal to V: the inside region
    // is pinched at that sample, where the welded surface would be two cones
    // sharing one vertex. The vertex is split, one per cone, and the copies
    // moved apart a little, so every vertex is manifold and none coincide.
    Volume v = Volume::allocate(Dims{5, 5, 5}, ValueType::U8);
    v.set_value(v.dims.index(2, 2, 1), 10);
    v.set_value(v.dims.index(2, 2, 2), 5);
    v.set_value(v.dims.index(2, 2, 3), 10);
    const double iso[] = {5.0};
    IsosurfaceStats stats;
    const TriangleMesh s = marching_tetrahedra(full_mesh(std::move(v)), iso, &stats);
    EXPECT_GT(stats.split_vertices, 0u);
    expect_welded(s);
    EXPECT_GT(enclosed_volume(s), 0.0);
    // The split copies stay within 1/100 of a grid step of the sample.
    std::size_t near = 0;
    for (const auto& p : s.points)
        if (std::abs(p[0] - 2) < 0.01 && std::abs(p[1] - 2) < 0.01 && std::abs(p[2] - 2) < 0.01) ++near;
    EXPECT_EQ(near, stats.split_vertices + 1);
}

TEST(Isosurface, SurfaceTouchingItselfAlongAnEdgeIsSplitThere) {
    // Two columns side by side, their middle samples equal to V and adjacent:
    // the inside region is pinched along the edge between them, where the
    // welded surface would have an edge in four faces. Both ends split.
    Volume v = Volume::allocate(Dims{6, 5, 5}, ValueType::U8);
    for (int x : {2, 3}) {
        v.set_value(v.dims.index(x, 2, 1), 10);
        v.set_value(v.dims.index(x, 2, 2), 5);
        v.set_value(v.dims.index(x, 2, 3), 10);
    }
    const double iso[] = {5.0};
    IsosurfaceStats stats;
    const TriangleMesh s = marching_tetrahedra(full_mesh(std::move(v)), iso, &stats);
    EXPECT_GE(stats.split_vertices, 2u);
    EXPECT_EQ(stats.nonmanifold_edges, 0u);
    expect_welded(s);
    EXPECT_GT(enclosed_volume(s), 0.0);
}

TEST(Isosurface, TwoSidedSheetOfSamplesEqualToTheIsovalueVanishes) {
    // A single plane of samples equal to V between outside samples: the
    // inside region has no volume, so nothing is left (each face came with its
    // opposite twin, and both are removed).
    Volume v = Volume::allocate(Dims{5, 5, 5}, ValueType::U8);
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 5; ++x) v.set_value(v.dims.index(x, y, 2), 7);
    const double iso[] = {7.0};
    IsosurfaceStats stats;
    const TriangleMesh s = marching_tetrahedra(full_mesh(std::move(v)), iso, &stats);
    EXPECT_EQ(s.faces.size(), 0u);
    EXPECT_EQ(s.points.size(), 0u);
    EXPECT_GT(stats.cancelled_faces + stats.degenerate_faces, 0u);
}

TEST(Isosurface, TorusHasEulerCharacteristicZero) {
    const int n = 33;
    Volume v = Volume::allocate(Dims{n, n, n}, ValueType::F64);
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                const double dx = x - 16.2, dy = y - 15.9, dz = z - 16.1;
                const double q = std::sqrt(dx * dx + dy * dy) - 9.0;
                v.set_value(v.dims.index(x, y, z), 16.0 - (q * q + dz * dz));
            }
    const double iso[] = {0.0};
    const TriangleMesh s = marching_tetrahedra(full_mesh(std::move(v)), iso);
    const Topology t = topology(s);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.nonmanifold_edges, 0u);
    EXPECT_EQ(t.misoriented_edges, 0u);
    EXPECT_EQ(t.euler(), 0);
    const double exact = 2 * std::numbers::pi * std::numbers::pi * 9.0 * 16.0;  // 2 pi^2 R r^2
    EXPECT_NEAR(enclosed_volume(s), exact, 0.03 * exact);  // tube radius 4: ~2% deficit
}

TEST(Isosurface, PlaneMeetingTheBoundaryIsOpenAndFacesDownTheGradient) {
    Volume v = Volume::allocate(Dims{17, 17, 17}, ValueType::F64);
    for (int64_t i = 0; i < v.count(); ++i) v.set_value(i, double(i % 17) - 10.5);  // f = x - 10.5
    const double iso[] = {0.0};
    const TriangleMesh s = marching_tetrahedra(full_mesh(std::move(v)), iso);
    const Topology t = topology(s);
    EXPECT_GT(t.boundary_edges, 0u);
    EXPECT_EQ(t.nonmanifold_edges, 0u);
    EXPECT_EQ(t.misoriented_edges, 0u);
    EXPECT_EQ(t.euler(), 1);  // a disc
    double area = 0;
    for (const auto& f : s.faces) {
        const auto &a = s.points[f[0]], &b = s.points[f[1]], &c = s.points[f[2]];
        const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
        const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
        const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
        EXPECT_LT(nx, 0.0);  // facing -x: towards decreasing field
        EXPECT_NEAR(ny, 0.0, 1e-12);
        EXPECT_NEAR(nz, 0.0, 1e-12);
        area += 0.5 * std::sqrt(nx * nx + ny * ny + nz * nz);
    }
    EXPECT_NEAR(area, 16.0 * 16.0, 1e-9);
    for (const auto& p : s.points) EXPECT_DOUBLE_EQ(p[0], 10.5);
    for (const auto& n : s.normals) EXPECT_NEAR(n[0], -1.0, 1e-12);
}

TEST(Isosurface, NoCrossingGivesNothingAndBadInputIsRefused) {
    TetMesh mesh = full_mesh(ball_volume(9, {4, 4, 4}, 3));
    const double far[] = {1e9};
    EXPECT_EQ(marching_tetrahedra(mesh, far).faces.size(), 0u);
    EXPECT_EQ(marching_tetrahedra(mesh, {}).faces.size(), 0u);
    const double nan[] = {std::nan("")};
    EXPECT_THROW(marching_tetrahedra(mesh, nan), Error);
    mesh.tets.push_back({0, 1, 2, 999999});
    const double zero[] = {0.0};
    EXPECT_THROW(marching_tetrahedra(mesh, zero), Error);
}

}  // namespace
}  // namespace tetlod
