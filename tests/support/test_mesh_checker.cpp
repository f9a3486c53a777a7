// Tests of the independent checker and the reference HT themselves: hand-built
// meshes with known defects must be caught, correct ones must pass.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>

#include "support/ht_reference.hpp"
#include "support/mesh_checker.hpp"
#include "support/volume_generators.hpp"

namespace tetlod::test {
namespace {

// Builds a mesh from corner coordinates (vertices shared by coordinate, each tet
// reoriented positively, values sampled from the volume).
TetMesh make_mesh(const Volume& v, const std::vector<TetPts>& tets) {
    TetMesh m;
    std::map<Pt, uint32_t> ids;
    for (TetPts t : tets) {
        if (tet_det(t) < 0) std::swap(t[2], t[3]);
        std::array<uint32_t, 4> q;
        for (int i = 0; i < 4; ++i) {
            auto [it, fresh] = ids.emplace(t[i], static_cast<uint32_t>(m.points.size()));
            if (fresh) {
                m.points.push_back(t[i]);
                m.values.push_back(v.value(t[i][0], t[i][1], t[i][2]));
            }
            q[i] = it->second;
        }
        m.tets.push_back(q);
    }
    return m;
}

std::vector<TetPts> roots_pts(int k) {
    std::vector<TetPts> r;
    for (auto& t : ht_roots(k)) r.push_back(t.x);
    return r;
}

bool has_message(const CheckReport& r, const std::string& needle) {
    for (auto& m : r.messages)
        if (m.find(needle) != std::string::npos) return true;
    return false;
}

TEST(MeshChecker, SixTetCubeIsValid) {
    for (int k : {0, 1, 2, 3}) {
        const int32_t L = 1 << k;
        Volume v = make_volume({L + 1, L + 1, L + 1}, ValueType::U8, Field::Noisy);
        TetMesh m = make_mesh(v, roots_pts(k));
        CheckOptions o;
        o.allowed = uniform_bound(std::numeric_limits<double>::infinity());
        EXPECT_TRUE(mesh_ok(v, m, o)) << "k=" << k;
    }
}

TEST(MeshChecker, LinearFieldHasZeroError) {
    Volume v = Volume::allocate({9, 9, 9}, ValueType::I32);
    for (int z = 0; z < 9; ++z)
        for (int y = 0; y < 9; ++y)
            for (int x = 0; x < 9; ++x) v.set_value(v.dims.index(x, y, z), 3 * x - 7 * y + 11 * z + 5);
    TetMesh m = make_mesh(v, roots_pts(3));
    CheckOptions o;
    o.allowed = uniform_bound(0.0);
    auto r = check_mesh(v, m, o);
    EXPECT_TRUE(r.ok()) << r.summary();
    EXPECT_EQ(r.max_error, 0.0);
}

TEST(MeshChecker, ExactTetErrorAndPointCount) {
    Volume v = Volume::allocate({3, 3, 3}, ValueType::U8);
    v.set_value(v.dims.index(1, 1, 1), 8);  // on the spine of every root
    TetPts kuhn = {Pt{0, 0, 0}, Pt{2, 0, 0}, Pt{2, 2, 0}, Pt{2, 2, 2}};
    TetStats s = exact_tet_stats(v, kuhn);
    EXPECT_EQ(s.points, 10);  // 2 >= x >= y >= z >= 0
    EXPECT_EQ(s.error, 8.0);
    EXPECT_EQ(s.fmin, 0.0);
    EXPECT_EQ(s.fmax, 8.0);
    // a point on a face only: (1,0,0) lies on edge (0,0,0)-(2,0,0)
    Volume w = Volume::allocate({3, 3, 3}, ValueType::U8);
    w.set_value(w.dims.index(1, 0, 0), 4);
    EXPECT_EQ(exact_tet_error(w, kuhn), 4.0);
    EXPECT_EQ(exact_tet_error(w, TetPts{Pt{0, 0, 0}, Pt{0, 2, 0}, Pt{2, 2, 0}, Pt{2, 2, 2}}), 0.0);
    // a dyadic error: value 1 at (2,1,0), whose interpolant on the half pyramid is 1/2
    TetPts half = {Pt{0, 0, 0}, Pt{2, 0, 0}, Pt{2, 2, 0}, Pt{1, 1, 1}};
    Volume u = Volume::allocate({3, 3, 3}, ValueType::U8);
    u.set_value(u.dims.index(1, 1, 0), 1);
    EXPECT_EQ(exact_tet_error(u, half), 1.0);  // (1,1,0) is on edge (0,0,0)-(2,2,0)
    // vertex order (orientation) must not matter
    Volume n = make_volume({5, 5, 5}, ValueType::I16, Field::Noisy);
    for (auto& r : ht_roots(2)) {
        TetPts a = r.x, b = r.x;
        std::swap(b[1], b[2]);
        EXPECT_EQ(exact_tet_stats(n, a).points, exact_tet_stats(n, b).points);
        EXPECT_EQ(exact_tet_error(n, a), exact_tet_error(n, b));
        EXPECT_GT(exact_tet_error(n, a), 0.0);
    }
}

TEST(MeshChecker, MissingTetIsCaught) {
    Volume v = make_volume({5, 5, 5}, ValueType::U8, Field::Smooth);
    auto t = roots_pts(2);
    t.pop_back();
    auto r = check_mesh(v, make_mesh(v, t), {});
    EXPECT_FALSE(r.ok());
    EXPECT_TRUE(has_message(r, "sum of 6*volume")) << r.summary();
    EXPECT_TRUE(has_message(r, "not on the box boundary")) << r.summary();
    EXPECT_TRUE(has_message(r, "covered by no tet")) << r.summary();
}

TEST(MeshChecker, TJunctionIsCaught) {
    Volume v = make_volume({5, 5, 5}, ValueType::U8, Field::Smooth);
    auto roots = ht_roots(2);
    std::vector<TetPts> t;
    for (int i = 1; i < 6; ++i) t.push_back(roots[i].x);
    for (auto& c : ht_children(roots[0])) t.push_back(c.x);  // split one tet only
    auto r = check_mesh(v, make_mesh(v, t), {});
    EXPECT_FALSE(r.ok());
    EXPECT_TRUE(has_message(r, "hanging vertex")) << r.summary();
    EXPECT_TRUE(has_message(r, "not on the box boundary")) << r.summary();
    // volume is still right: only conformity fails
    EXPECT_FALSE(has_message(r, "sum of 6*volume")) << r.summary();
    // the same mesh with the whole root diamond split is conforming
    t.clear();
    for (auto& rt : roots)
        for (auto& c : ht_children(rt)) t.push_back(c.x);
    EXPECT_TRUE(mesh_ok(v, make_mesh(v, t), {}));
}

TEST(MeshChecker, WrongValueOrientationDuplicateAreCaught) {
    Volume v = make_volume({3, 3, 3}, ValueType::I16, Field::Noisy);
    TetMesh m = make_mesh(v, roots_pts(1));
    {
        TetMesh b = m;
        b.values[2] += 1;
        auto r = check_mesh(v, b, {});
        EXPECT_TRUE(has_message(r, "!= volume")) << r.summary();
    }
    {
        TetMesh b = m;
        std::swap(b.tets[3][0], b.tets[3][1]);
        auto r = check_mesh(v, b, {});
        EXPECT_TRUE(has_message(r, "orientation")) << r.summary();
    }
    {
        TetMesh b = m;
        b.points.push_back(b.points[0]);
        b.values.push_back(b.values[0]);
        b.tets[0][0] = static_cast<uint32_t>(b.points.size() - 1);
        auto r = check_mesh(v, b, {});
        EXPECT_TRUE(has_message(r, "duplicate vertex")) << r.summary();
    }
    {
        TetMesh b = m;
        b.tets.push_back(b.tets[0]);
        auto r = check_mesh(v, b, {});
        EXPECT_FALSE(r.ok());
        EXPECT_TRUE(has_message(r, "used by 3 tets") || has_message(r, "overlap")) << r.summary();
    }
    {
        TetMesh b = m;
        b.points[0] = {5, 0, 0};
        auto r = check_mesh(v, b, {});
        EXPECT_TRUE(has_message(r, "outside the data box")) << r.summary();
    }
}

TEST(MeshChecker, BoundIsChecked) {
    Volume v = make_volume({9, 9, 9}, ValueType::U8, Field::Noisy);
    TetMesh m = make_mesh(v, roots_pts(3));
    double worst = 0;
    for (auto& t : roots_pts(3)) worst = std::max(worst, exact_tet_error(v, t));
    ASSERT_GT(worst, 0);
    CheckOptions o;
    o.allowed = uniform_bound(worst);
    auto r = check_mesh(v, m, o);
    EXPECT_TRUE(r.ok()) << r.summary();
    EXPECT_EQ(r.max_error, worst);
    o.allowed = uniform_bound(worst - 0.25);
    r = check_mesh(v, m, o);
    EXPECT_TRUE(has_message(r, "bound:")) << r.summary();
}

TEST(MeshChecker, TetMeetsBox) {
    TetPts t = {Pt{0, 0, 0}, Pt{4, 0, 0}, Pt{4, 4, 0}, Pt{4, 4, 4}};  // 4 >= x >= y >= z >= 0
    EXPECT_TRUE(tet_meets_box(t, {4, 4, 4}, {6, 6, 6}));     // corner touch
    EXPECT_FALSE(tet_meets_box(t, {5, 0, 0}, {6, 6, 6}));
    EXPECT_FALSE(tet_meets_box(t, {0, 3, 0}, {1, 4, 0}));    // bboxes overlap, tet does not
    EXPECT_TRUE(tet_meets_box(t, {1, 1, 1}, {1, 1, 1}));     // on the spine
    EXPECT_TRUE(tet_meets_box(t, {2, 1, 0}, {3, 2, 0}));
    EXPECT_FALSE(tet_meets_box(t, {0, 1, 0}, {0, 4, 4}));    // x=0 face: only the origin, y>=1 misses
    EXPECT_TRUE(tet_meets_box(t, {-3, -3, -3}, {0, 0, 0}));
}

TEST(MeshChecker, PadToCube) {
    Volume v = make_volume({5, 3, 2}, ValueType::F32, Field::Smooth);
    Volume p = pad_to_cube(v);
    ASSERT_EQ(p.dims, (Dims{5, 5, 5}));
    EXPECT_EQ(p.value(4, 4, 4), v.value(4, 2, 1));
    EXPECT_EQ(p.value(1, 2, 0), v.value(1, 2, 0));
    EXPECT_EQ(p.value(0, 3, 3), v.value(0, 2, 1));
}

// ---- the reference hierarchy

TEST(HtReference, EveryLevelIsAConformingTiling) {
    const int k = 2;
    HtHierarchy h(k);
    Volume v = make_volume({5, 5, 5}, ValueType::U8, Field::Constant);
    ASSERT_EQ(h.tets.size(), 6u * ((1u << (3 * k + 1)) - 1));
    for (int l = 0; l <= 3 * k; ++l) {
        std::vector<TetPts> lev;
        for (std::size_t i = HtHierarchy::level_begin(l); i < HtHierarchy::level_begin(l + 1); ++i) {
            lev.push_back(h.tets[i].x);
            // x0 - x_tag is the unique longest edge
            const HtTet& t = h.tets[i];
            auto len2 = [&](int a, int b) {
                int64_t s = 0;
                for (int c = 0; c < 3; ++c) s += int64_t(t.x[a][c] - t.x[b][c]) * (t.x[a][c] - t.x[b][c]);
                return s;
            };
            int64_t spine = len2(0, t.tag);
            for (int a = 0; a < 4; ++a)
                for (int b = a + 1; b < 4; ++b)
                    if (!(a == 0 && b == t.tag)) {
                        ASSERT_LT(len2(a, b), spine) << "level " << l;
                    }
        }
        ASSERT_EQ(lev.size(), 6u << l);
        EXPECT_TRUE(mesh_ok(v, make_mesh(v, lev), {})) << "level " << l;
    }
}

TEST(HtReference, DiamondsAreKeyedByEveryNonCornerPoint) {
    const int k = 3;
    HtHierarchy h(k);
    std::map<Pt, std::pair<int, int>> d;  // centre -> (count, level)
    for (std::size_t i = 0; i < HtHierarchy::level_begin(3 * k); ++i) {
        auto& e = d[ht_spine_mid(h.tets[i])];
        if (e.first) {
            EXPECT_EQ(e.second, h.tets[i].level);
        }
        e.first++;
        e.second = h.tets[i].level;
    }
    const int N = (1 << k) + 1;
    EXPECT_EQ(static_cast<int>(d.size()), N * N * N - 8);
    for (auto& [c, e] : d) EXPECT_EQ(e.first, diamond_size_in_cube(c, k)) << c[0] << "," << c[1] << "," << c[2];
}

TEST(HtReference, ShapeQuality) {
    HtHierarchy h(2);
    for (std::size_t i = 0; i < h.tets.size(); ++i) {
        double expect = h.tets[i].level % 3 == 2 ? std::sqrt(5.0) / 2 : std::sqrt(3.0) / 2;
        ASSERT_NEAR(shape_ratio(h.tets[i].x), expect, 1e-12) << "level " << h.tets[i].level;
    }
}

TEST(HtReference, OracleCoarsestMeshCounts) {
    // counts from docs/ht.md ("Volumes that are not (2^k+1)^3"), unbounded error, no padding
    struct Case {
        Dims dims;
        std::size_t tets;
    };
    for (auto c : {Case{{33, 33, 33}, 6}, Case{{32, 32, 32}, 12738}, Case{{17, 17, 17}, 6}}) {
        Volume v = make_volume(c.dims, ValueType::U8, Field::Noisy);
        HtHierarchy h(5);
        auto r = oracle_extract(h, v, uniform_bound(std::numeric_limits<double>::infinity()));
        if (c.dims.x == 17) {
            HtHierarchy h4(4);
            r = oracle_extract(h4, v, uniform_bound(std::numeric_limits<double>::infinity()));
        }
        EXPECT_EQ(r.mesh.size(), c.tets) << c.dims.x;
    }
}

TEST(HtReference, OracleMeshesPassTheChecker) {
    Volume v = make_volume({13, 9, 7}, ValueType::U8, Field::Smooth);
    HtHierarchy h(4);
    for (double eps : {-1.0, 0.0, 2.0, 10.0, std::numeric_limits<double>::infinity()}) {
        auto r = oracle_extract(h, v, uniform_bound(eps));
        std::vector<TetPts> t;
        for (auto& key : r.mesh) {
            TetPts p;
            for (int i = 0; i < 4; ++i) p[i] = {key[3 * i], key[3 * i + 1], key[3 * i + 2]};
            t.push_back(p);
        }
        TetMesh m = make_mesh(v, t);
        CheckOptions o;
        o.allowed = uniform_bound(std::max(eps, 0.0));
        EXPECT_TRUE(mesh_ok(v, m, o)) << "eps " << eps;
        if (eps < 0) {
            EXPECT_EQ(m.tets.size(), 6u * 12 * 8 * 6);
        }
        // the minimality check finds nothing in the oracle's own mesh
        MeshWalk w = walk_mesh(m, 4, {12, 8, 6});
        EXPECT_TRUE(w.errors.empty()) << w.errors.front();
        int64_t cand = 0;
        auto mm = find_mergeable_diamonds(v, w, uniform_bound(eps), {}, &cand);
        EXPECT_TRUE(mm.empty()) << mm.front();
        // and an over-refined mesh is caught: split one more diamond of the oracle
        if (eps == 10.0) {
            EXPECT_GT(cand, 0);
            auto mm2 = find_mergeable_diamonds(v, w, uniform_bound(1e9), {}, &cand);
            EXPECT_FALSE(mm2.empty());
        }
    }
}

}  // namespace
}  // namespace tetlod::test
