// MtBuildOptions::pass_error_cap: a bricked build whose early passes stop at an error
// cap must give coarse LODs close to those of one greedy decimation of the whole
// volume. Without the caps every brick decimated to the end and its frozen border
// stayed fine in every coarse LOD (iron 68^3 at 10 % of the range: 6.3x the tets of
// one brick). Bounds and conformity are checked by the independent mesh checker.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>

#include "mt_test_util.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod::test {
namespace {

TEST(MtPassCaps, CoarseLodsOfABrickedBuildStayNearOneBrick) {
    const Volume v = make_volume({41, 37, 33}, ValueType::U8, Field::Smooth, 11);
    const double span = v.range()[1] - v.range()[0];
    MtBuildOptions one;
    one.brick_cells = 0;
    MtBuildOptions capped;
    capped.brick_cells = 8;  // 5 x 5 x 4 bricks, then 3, 2, 1 per axis: four passes
    MtBuildOptions uncapped = capped;
    uncapped.pass_error_cap = std::numeric_limits<double>::infinity();
    const MtModel a = MtModel::build(v, one), b = MtModel::build(v, capped), c = MtModel::build(v, uncapped);
    for (double f : {0.05, 0.1, 0.3}) {
        LodQuery q;
        q.error_in = f * span;
        const TetMesh ma = a.extract(q), mb = b.extract(q), mc = c.extract(q);
        EXPECT_TRUE(mesh_ok(v, mb, mt_check_options(q, v))) << "capped build at " << f;
        std::printf("[ mt ] uniform %.0f%%: one brick %zu tets, capped passes %zu, uncapped %zu\n", f * 100,
                    ma.tet_count(), mb.tet_count(), mc.tet_count());
        EXPECT_LE(double(mb.tet_count()), 1.5 * double(ma.tet_count())) << "at " << f << " of the range";
    }
}

// Below the last-but-one pass's cap (3 % of the range) only the passes before it shape
// the LOD. With nested bricks the faces of that pass had been frozen since pass 0, so
// such LODs carried them at full resolution; the faces now shift between passes
// (each is frozen in one pass only), so a LOD carries the faces of one pass at the
// resolution of the cap before it (1/8 of the next). Printed when written (one brick /
// shifted / nested): 58,468 / 59,944 / 65,250 tets at 0.5 %, 24,532 / 30,823 / 35,124
// at 1 %, 9,270 / 17,086 / 19,896 at 2 %.
TEST(MtPassCaps, LodsBelowTheTopCapStayNearOneBrick) {
    const Volume v = make_volume({41, 37, 33}, ValueType::U8, Field::Smooth, 11);
    const double span = v.range()[1] - v.range()[0];
    MtBuildOptions one;
    one.brick_cells = 0;
    MtBuildOptions bricked;
    bricked.brick_cells = 8;
    const MtModel a = MtModel::build(v, one), b = MtModel::build(v, bricked);
    for (const auto& [f, most] : {std::pair{0.005, 1.15}, {0.01, 1.35}, {0.02, 2.0}}) {
        LodQuery q;
        q.error_in = f * span;
        const TetMesh ma = a.extract(q), mb = b.extract(q);
        EXPECT_TRUE(mesh_ok(v, mb, mt_check_options(q, v))) << "bricked build at " << f;
        std::printf("[ mt ] uniform %.1f%%: one brick %zu tets, bricked %zu (%.2fx)\n", f * 100, ma.tet_count(),
                    mb.tet_count(), double(mb.tet_count()) / double(ma.tet_count()));
        EXPECT_LE(double(mb.tet_count()), most * double(ma.tet_count())) << "at " << f << " of the range";
    }
}

TEST(MtPassCaps, RefusesANegativeOrNanCap) {
    const Volume v = make_volume({9, 9, 9}, ValueType::U8, Field::Smooth, 3);
    MtBuildOptions o;
    o.pass_error_cap = -1;
    EXPECT_THROW(MtModel::build(v, o), Error);
    o.pass_error_cap = std::nan("");
    EXPECT_THROW(MtModel::build(v, o), Error);
}

}  // namespace
}  // namespace tetlod::test
