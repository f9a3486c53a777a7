// MtBuildOptions::max_shape_ratio (CLI --max-shape-ratio): no tet of any LOD mesh
// has a circumradius / shortest-edge ratio above the cap (unless the full-
// resolution mesh already has it), measured here with an independent formula;
// the cap costs tets, never correctness (bounds checked by the mesh checker).
#include <gtest/gtest.h>

#include <cmath>

#include "mt_test_util.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod::test {
namespace {

// Circumradius / shortest edge of a tet in index space, from the Cayley-Menger
// style closed form R = |a^2 (b x c) + b^2 (c x a) + c^2 (a x b)| / (12 V).
double shape_ratio(const TetMesh& m, std::size_t t) {
    const auto& p0 = m.points[m.tets[t][0]];
    double e[3][3];
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) e[i][a] = double(m.points[m.tets[t][i + 1]][a] - p0[a]);
    auto cross = [](const double* u, const double* v, double* w) {
        w[0] = u[1] * v[2] - u[2] * v[1], w[1] = u[2] * v[0] - u[0] * v[2], w[2] = u[0] * v[1] - u[1] * v[0];
    };
    auto dot = [](const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
    double bc[3], ca[3], ab[3];
    cross(e[1], e[2], bc), cross(e[2], e[0], ca), cross(e[0], e[1], ab);
    const double six_v = std::abs(dot(e[0], bc));
    double num[3];
    for (int a = 0; a < 3; ++a) num[a] = dot(e[0], e[0]) * bc[a] + dot(e[1], e[1]) * ca[a] + dot(e[2], e[2]) * ab[a];
    const double radius = std::sqrt(dot(num, num)) / (2 * six_v);
    double shortest = 1e300;
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
            double d2 = 0;
            for (int a = 0; a < 3; ++a) {
                const double d = double(m.points[m.tets[t][i]][a] - m.points[m.tets[t][j]][a]);
                d2 += d * d;
            }
            shortest = std::min(shortest, std::sqrt(d2));
        }
    return radius / shortest;
}

TEST(MtShapeCap, NoTetAboveTheCapAtAnyLod) {
    const Volume v = make_volume({17, 13, 11}, ValueType::U8, Field::Smooth, 5);
    const double span = v.range()[1] - v.range()[0];
    MtBuildOptions free_opt;
    const MtModel free = MtModel::build(v, free_opt);
    MtBuildOptions capped_opt;
    capped_opt.max_shape_ratio = 2.0;
    const MtModel capped = MtModel::build(v, capped_opt);
    LodQuery full;
    full.full = true;
    double floor = 0;  // the full-resolution mesh's own worst ratio
    const TetMesh fm = capped.extract(full);
    for (std::size_t t = 0; t < fm.tets.size(); ++t) floor = std::max(floor, shape_ratio(fm, t));
    double worst_free = 0;
    for (double f : {0.001, 0.01, 0.05, 0.1, 1.0}) {
        LodQuery q;
        q.error_in = f * span;
        const TetMesh a = capped.extract(q), b = free.extract(q);
        EXPECT_TRUE(mesh_ok(v, a, mt_check_options(q, v)));
        double worst = 0;
        for (std::size_t t = 0; t < a.tets.size(); ++t) worst = std::max(worst, shape_ratio(a, t));
        EXPECT_LE(worst, std::max(2.0, floor) * (1 + 1e-9)) << "error " << f;
        for (std::size_t t = 0; t < b.tets.size(); ++t) worst_free = std::max(worst_free, shape_ratio(b, t));
    }
    EXPECT_GT(worst_free, 2.0);  // the cap changed something
}

}  // namespace
}  // namespace tetlod::test
