// MtBuildOptions::pass_error_cap: a bricked build whose early passes stop at an error
// cap must give coarse LODs close to those of one greedy decimation of the whole
// volume. Without the caps every brick decimated to the end and its frozen border
// stayed fine in every coarse LOD (iron 68^3 at 10 % of the range: 6.3x the tets of
// one brick). Bounds and conformity are checked by the independent mesh checker.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

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
