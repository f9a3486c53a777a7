// resample_mesh against a brute-force oracle: every grid point tested against
// every tet (O(points x tets), small grids only), the value of the first tet that
// contains it computed independently (int64 numerators, exact rational rounding
// for integers; double for floats). Also: meshes that represent the data exactly
// (full resolution, error 0) give the data back bit for bit, for HT and MT.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <random>

#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/analysis/mesh_resample.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Volume smooth_volume(Dims d, ValueType t, uint32_t seed) {
    Volume v = Volume::allocate(d, t);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> noise(-3, 3);
    for (int64_t z = 0; z < d.z; ++z)
        for (int64_t y = 0; y < d.y; ++y)
            for (int64_t x = 0; x < d.x; ++x) {
                double f = 60 + 50 * std::sin(0.5 * x) * std::cos(0.4 * y) + 8 * z + noise(rng);
                if (t == ValueType::I16) f = f * 20 - 1500;
                if (t == ValueType::F32) f = f * 0.013 - 0.4;
                v.set_value(d.index(x, y, z), is_float(t) ? f : std::round(f));
            }
    return v;
}

int64_t det3(const std::array<int32_t, 3>& a, const std::array<int32_t, 3>& b,
             const std::array<int32_t, 3>& c, const std::array<int32_t, 3>& d) {
    const int64_t ax = b[0] - a[0], ay = b[1] - a[1], az = b[2] - a[2];
    const int64_t bx = c[0] - a[0], by = c[1] - a[1], bz = c[2] - a[2];
    const int64_t cx = d[0] - a[0], cy = d[1] - a[1], cz = d[2] - a[2];
    return ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
}

// Value of grid point p by brute force, or nothing when no tet contains it.
std::optional<double> oracle(const TetMesh& m, std::array<int32_t, 3> p, bool integer) {
    for (const auto& t : m.tets) {
        std::array<std::array<int32_t, 3>, 4> v;
        for (int i = 0; i < 4; ++i) v[i] = m.points[t[i]];
        const int64_t D = det3(v[0], v[1], v[2], v[3]);
        if (D <= 0) continue;
        std::array<int64_t, 4> n;
        bool inside = true;
        for (int i = 0; i < 4; ++i) {
            auto w = v;
            w[i] = p;
            n[i] = det3(w[0], w[1], w[2], w[3]);
            inside = inside && n[i] >= 0;
        }
        if (!inside) continue;
        if (integer) {
            int64_t num = 0;
            for (int i = 0; i < 4; ++i) num += n[i] * int64_t(m.values[t[i]]);
            // nearest, ties up: floor((2 num + D) / 2D)
            const int64_t a = 2 * num + D, b = 2 * D;
            int64_t q = a / b;
            if (a % b != 0 && a < 0) --q;
            return double(q);
        }
        double s = 0;
        for (int i = 0; i < 4; ++i) s += double(n[i]) / double(D) * m.values[t[i]];
        return s;
    }
    return std::nullopt;
}

void expect_matches_oracle(const TetMesh& m, const Dims& d, ValueType t) {
    MeshResampleStats st;
    const Volume r = resample_mesh(m, d, t, &st);
    EXPECT_EQ(st.grid_points, uint64_t(d.count()));
    uint64_t covered = 0;
    for (int32_t z = 0; z < d.z; ++z)
        for (int32_t y = 0; y < d.y; ++y)
            for (int32_t x = 0; x < d.x; ++x) {
                const auto o = oracle(m, {x, y, z}, !is_float(t));
                const double got = r.value(x, y, z);
                if (!o) {
                    EXPECT_EQ(got, 0.0);
                    continue;
                }
                ++covered;
                if (is_float(t))
                    ASSERT_NEAR(got, *o, 1e-5 * (1 + std::fabs(*o))) << x << "," << y << "," << z;
                else
                    ASSERT_EQ(got, *o) << x << "," << y << "," << z;
            }
    EXPECT_EQ(st.covered, covered);
}

TEST(MeshResample, SingleTetAgainstOracle) {
    TetMesh m;
    m.points = {{0, 0, 0}, {7, 1, 0}, {2, 6, 1}, {1, 2, 5}};
    m.values = {0, 100, 37, 255};
    m.tets = {{0, 1, 2, 3}};
    ASSERT_GT(det3(m.points[0], m.points[1], m.points[2], m.points[3]), 0);
    for (ValueType t : {ValueType::U8, ValueType::I16, ValueType::F32, ValueType::F64})
        expect_matches_oracle(m, Dims{9, 8, 7}, t);
    // Negatively oriented input is handled as well (orientation only flips signs).
    std::swap(m.tets[0][0], m.tets[0][1]);
    const Volume a = resample_mesh(m, Dims{9, 8, 7}, ValueType::U8);
    std::swap(m.tets[0][0], m.tets[0][1]);
    const Volume b = resample_mesh(m, Dims{9, 8, 7}, ValueType::U8);
    EXPECT_EQ(a.data, b.data);
}

TEST(MeshResample, ClampsAndClips) {
    TetMesh m;  // partly outside the grid, values beyond i8: f = -1000 (4 - x - y - z) / 16
    m.points = {{-4, -4, -4}, {12, -4, -4}, {-4, 12, -4}, {-4, -4, 12}};
    m.values = {-1000, 0, 0, 0};
    m.tets = {{0, 1, 2, 3}};
    MeshResampleStats st;
    const Volume r = resample_mesh(m, Dims{5, 5, 5}, ValueType::I8, &st);
    EXPECT_EQ(r.value(0, 0, 0), -128.0);  // -250 clamped
    EXPECT_EQ(r.value(1, 1, 1), -62.0);   // -62.5: ties towards +inf
    EXPECT_EQ(r.value(2, 1, 0), -62.0);
    EXPECT_EQ(r.value(4, 0, 0), 0.0);
    EXPECT_EQ(r.value(0, 2, 1), -62.0);
    EXPECT_EQ(st.covered, 35u);  // x + y + z <= 4
    EXPECT_EQ(r.value(4, 4, 4), 0.0);
}

TEST(MeshResample, HtMeshesAgainstOracle) {
    for (ValueType t : {ValueType::U8, ValueType::I16, ValueType::F32}) {
        SCOPED_TRACE(value_type_name(t));
        const Dims d{9, 7, 6};
        const HtModel model = HtModel::build(smooth_volume(d, t, 7));
        for (double e : {kInf, 10.0, 2.0}) {
            LodQuery q;
            q.error_in = e;
            const TetMesh m = model.extract(q);
            expect_matches_oracle(m, d, t);
            const Volume r = resample_mesh(m, d, t);
            const Volume& f = model.field();
            double maxdev = 0;
            for (int64_t i = 0; i < d.count(); ++i)
                maxdev = std::max(maxdev, std::fabs(r.value(i) - f.value(i)));
            const double bound = is_float(t) ? e * (1 + 1e-6) : std::floor(e + 0.5);
            EXPECT_LE(maxdev, bound) << "error " << e;
        }
    }
}

TEST(MeshResample, ExactMeshesGiveTheDataBack) {
    for (ValueType t : {ValueType::U8, ValueType::I16, ValueType::F32}) {
        SCOPED_TRACE(value_type_name(t));
        const Dims d{11, 9, 8};
        const Volume v = smooth_volume(d, t, 3);
        const HtModel ht = HtModel::build(Volume(v));
        const MtModel mt = MtModel::build(Volume(v));
        LodQuery full;
        full.full = true;
        LodQuery zero;
        zero.error_in = 0;
        for (const TetMesh& m : {ht.extract(full), ht.extract(zero), mt.extract(full), mt.extract(zero)}) {
            MeshResampleStats st;
            const Volume r = resample_mesh(m, d, t, &st);
            EXPECT_EQ(st.covered, uint64_t(d.count()));
            EXPECT_EQ(st.degenerate_tets, 0u);
            EXPECT_EQ(r.data, v.data) << m.tet_count() << " tets";
        }
    }
}

TEST(MeshResample, IndependentOfTetOrderAndVertexOrder) {
    // Points on shared faces and edges get their value from whichever tet comes
    // first: reversing the tets and rotating their vertices must not change a bit.
    for (ValueType t : {ValueType::U8, ValueType::I16, ValueType::F32, ValueType::F64}) {
        SCOPED_TRACE(value_type_name(t));
        const Dims d{13, 11, 10};
        const HtModel model = HtModel::build(smooth_volume(d, t == ValueType::F64 ? ValueType::F32 : t, 5));
        for (double e : {1.0, 6.0, kInf}) {
            LodQuery q;
            q.error_in = e;
            TetMesh m = model.extract(q);
            const Volume a = resample_mesh(m, d, t);
            std::reverse(m.tets.begin(), m.tets.end());
            for (auto& tet : m.tets) tet = {tet[1], tet[2], tet[0], tet[3]};  // even permutation
            const Volume b = resample_mesh(m, d, t);
            EXPECT_EQ(a.data, b.data) << "error " << e;
        }
    }
}

TEST(MeshResample, LargeCoarseMeshIsLinearTime) {
    // A 129^3 grid covered by the 6 tets of the coarsest HT: must not scan per tet x point.
    const Dims d{129, 129, 129};
    Volume v = Volume::allocate(d, ValueType::U8);
    const HtModel model = HtModel::build(std::move(v));
    LodQuery q;
    const TetMesh m = model.extract(q);
    MeshResampleStats st;
    const Volume r = resample_mesh(m, d, ValueType::U8, &st);
    EXPECT_EQ(st.covered, uint64_t(d.count()));
    // Linear work, counted rather than timed: each tet visits only its own
    // points, so the points visited are the points covered plus the repeats on
    // faces shared by two tets (at most one face's worth per tet here: 6 tets
    // x 129^2), never tets x points (6 x 129^3); the rows scanned are at most
    // one bounding box of rows per tet.
    const uint64_t n = uint64_t(d.x), tets = m.tets.size();
    ASSERT_GT(tets, 0u);
    EXPECT_GE(st.points_visited, st.covered);
    EXPECT_LE(st.points_visited, st.covered + tets * n * n);
    EXPECT_LE(st.rows_scanned, tets * n * n);
    EXPECT_LT(st.points_visited, 2 * uint64_t(d.count()));  // a per-tet scan of all points: 6x
}

TEST(MeshResample, WorkIsPointsCoveredPlusSharedFacesOnAFineMesh) {
    // The full-resolution mesh of a 17^3 grid (6 tets per cell in the HT):
    // every point visited once per tet containing it, so the visits are bounded
    // by the covered points times the largest number of tets sharing a point,
    // and far below tets x points.
    const Dims d{17, 17, 17};
    Volume v = Volume::allocate(d, ValueType::U8);
    for (int64_t i = 0; i < v.count(); ++i) v.set_value(i, double(i % 251));
    const HtModel model = HtModel::build(std::move(v));
    LodQuery q;
    q.full = true;
    const TetMesh m = model.extract(q);
    MeshResampleStats st;
    resample_mesh(m, d, ValueType::U8, &st);
    EXPECT_EQ(st.covered, uint64_t(d.count()));
    // Each tet holds its 4 corners and no other grid point (side 1), so visits
    // are exactly 4 per tet.
    EXPECT_EQ(st.points_visited, 4 * uint64_t(m.tets.size()));
    EXPECT_LE(st.rows_scanned, 4 * uint64_t(m.tets.size()));
}

TEST(MeshResample, BadInputThrows) {
    TetMesh m;
    m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    m.values = {1, 2, 3, 4};
    m.tets = {{0, 1, 2, 7}};
    EXPECT_THROW(resample_mesh(m, Dims{2, 2, 2}, ValueType::U8), Error);
    m.tets = {{0, 1, 2, 3}};
    m.values.pop_back();
    EXPECT_THROW(resample_mesh(m, Dims{2, 2, 2}, ValueType::U8), Error);
    m.values.push_back(4);
    EXPECT_THROW(resample_mesh(m, Dims{0, 2, 2}, ValueType::U8), Error);
}

}  // namespace
}  // namespace tetlod
