// Evaluations walk their points on the arena's spare threads while decimate_brick's
// spare_threads flag reads true (the last pass from its start, any pass once all its
// bricks have started): the brick's result must be the sequential one, byte for byte,
// the parallel walks must actually have run, and the flag may change at any moment.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <numeric>
#include <thread>

#include <tbb/task_arena.h>

#include "mt_decimate.hpp"
#include "mt_test_util.hpp"

namespace tetlod::test {
namespace {

struct BrickRun {
    mt::BrickResult result;
    mt::NodeState nodes;
};

/// `toggle`: the flag flips every few microseconds while the brick runs (a pass's
/// threads finishing their bricks set it at moments no result may depend on).
BrickRun decimate_whole_volume(const Volume& v, bool parallel_points, bool toggle = false) {
    BrickRun run;
    const uint32_t n = uint32_t(v.count());
    run.nodes.node.resize(n);
    std::iota(run.nodes.node.begin(), run.nodes.node.end(), 0u);
    run.nodes.label.assign(n, 0);
    run.nodes.err.assign(n, 0.0f);
    mt::BrickBox box;
    box.hi = {v.dims.x - 1, v.dims.y - 1, v.dims.z - 1};
    const MtBuildOptions options;
    tbb::task_arena arena(2);
    std::atomic<bool> spare{parallel_points}, done{false};
    std::thread flipper;
    if (toggle)
        flipper = std::thread([&] {
            while (!done) {
                spare = !spare.load();
                std::this_thread::sleep_for(std::chrono::microseconds(50));
            }
        });
    arena.execute([&] { run.result = mt::decimate_brick(v, options, box, {}, run.nodes, {}, &spare); });
    done = true;
    if (flipper.joinable()) flipper.join();
    return run;
}

TEST(MtParallelWalks, SameBrickAsTheSequentialWalk) {
    for (auto [d, t, f] : {std::tuple{Dims{25, 23, 21}, ValueType::U8, Field::Smooth},
                           std::tuple{Dims{17, 19, 16}, ValueType::F32, Field::Noisy},
                           std::tuple{Dims{21, 18, 20}, ValueType::I16, Field::Plateau}}) {
        SCOPED_TRACE(dims_str(d));
        const Volume v = make_volume(d, t, f, 3);
        const BrickRun seq = decimate_whole_volume(v, false), all = decimate_whole_volume(v, true),
                       flipping = decimate_whole_volume(v, false, true);
        EXPECT_EQ(seq.result.stats.parallel_walks, 0u);
        // A target walk goes parallel only past its first kSequentialPoints points.
        EXPECT_GT(all.result.stats.parallel_walks, 0u) << "no target walk got past its sequential part";
        // The owned points' blocks were squeezed (the bricks below compare with it).
        EXPECT_GT(seq.result.stats.compactions, 0u) << "no compaction of the point blocks ran";
        for (const BrickRun* p : {&all, &flipping}) {
        const BrickRun& par = *p;
        ASSERT_EQ(seq.result.updates.size(), par.result.updates.size());
        for (size_t k = 0; k < seq.result.updates.size(); ++k) {
            const MtUpdate &a = seq.result.updates[k], &b = par.result.updates[k];
            ASSERT_TRUE(a.w == b.w && a.s == b.s && a.label == b.label && a.error == b.error && a.star == b.star)
                << "update " << k;
        }
        EXPECT_EQ(seq.result.mask_bit_count, par.result.mask_bit_count);
        EXPECT_TRUE(seq.result.mask_bits == par.result.mask_bits);
        EXPECT_TRUE(seq.result.mesh.bytes == par.result.mesh.bytes);
        EXPECT_TRUE(seq.nodes.node == par.nodes.node);
        EXPECT_TRUE(seq.nodes.label == par.nodes.label);
        EXPECT_TRUE(seq.nodes.err == par.nodes.err);
        // The walks are the same work: the statistics other than the walks agree too.
        EXPECT_EQ(seq.result.stats.evaluations, par.result.stats.evaluations);
        EXPECT_EQ(seq.result.stats.located, par.result.stats.located);
        EXPECT_EQ(seq.result.stats.gathered, par.result.stats.gathered);
        }
    }
}

}  // namespace
}  // namespace tetlod::test
