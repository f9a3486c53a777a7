// MtBuildOptions::progress: the reports of the bricked build (monotone, ending at the
// total, serialized) and the model's independence from them, for 1 and 2 threads.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <vector>

#include "support/volume_generators.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/models/mt/mt_model.hpp"

using namespace tetlod;
using namespace tetlod::test;

namespace {

struct Report {
    uint64_t done, total;
};

}  // namespace

TEST(MtBuildProgress, MonotoneToTheTotalAndTheSameBytes) {
    // Awkward dims, bricks smaller than the volume in every direction: three passes
    // (4, 8, then 16 cells), bricks cut short at the far faces.
    const Volume v = make_volume({17, 11, 14}, ValueType::U8, Field::Noisy, 5);
    MtBuildOptions plain;
    plain.brick_cells = 4;
    plain.threads = 1;
    const std::vector<uint8_t> reference = encode_mt(MtModel::build(v, plain));
    for (int threads : {1, 2}) {
        SCOPED_TRACE("threads " + std::to_string(threads));
        std::vector<Report> seen;
        std::atomic<int> inside{0};
        bool overlapped = false;
        MtBuildOptions o = plain;
        o.threads = threads;
        o.progress = [&](uint64_t done, uint64_t total) {
            if (++inside != 1) overlapped = true;  // calls must not overlap
            seen.push_back({done, total});
            --inside;
        };
        const std::vector<uint8_t> bytes = encode_mt(MtModel::build(v, o));
        EXPECT_TRUE(bytes == reference) << "the callback changed the model";
        EXPECT_FALSE(overlapped);
        ASSERT_GE(seen.size(), 2u);
        EXPECT_EQ(seen.front().done, 0u);
        const uint64_t total = seen.front().total;
        EXPECT_GT(total, 0u);
        // pass 0: 4x3x4 bricks, pass 1: 2x2x2, pass 2: 1, each reported once, after the start.
        EXPECT_EQ(seen.size(), 1u + 48u + 8u + 1u);
        for (size_t i = 1; i < seen.size(); ++i) {
            EXPECT_EQ(seen[i].total, total);
            EXPECT_GE(seen[i].done, seen[i - 1].done) << "call " << i;
            EXPECT_LE(seen[i].done, total) << "call " << i;
        }
        EXPECT_EQ(seen.back().done, total);
    }
}

TEST(MtBuildProgress, OneBrickStillReportsStartAndEnd) {
    const Volume v = make_volume({9, 7, 6}, ValueType::F32, Field::Noisy, 2);
    MtBuildOptions o;
    o.brick_cells = 0;  // the whole volume in one brick
    std::vector<Report> seen;
    o.progress = [&](uint64_t done, uint64_t total) { seen.push_back({done, total}); };
    MtModel::build(v, o);
    ASSERT_EQ(seen.size(), 2u);
    EXPECT_EQ(seen[0].done, 0u);
    // One pass of one brick: its share is every grid point.
    EXPECT_EQ(seen[0].total, uint64_t(9 * 7 * 6));
    EXPECT_EQ(seen[1].done, seen[1].total);
}

TEST(MtBuildProgress, OneLargeBrickMovesBeforeItEnds) {
    // The last pass is one brick: without reports from inside it, a long build would sit
    // at one value. 31^3 points in one brick: more than 4,096 collapses.
    const Volume v = make_volume({31, 31, 31}, ValueType::U8, Field::Smooth, 4);
    MtBuildOptions o;
    o.brick_cells = 0;
    std::vector<Report> seen;
    o.progress = [&](uint64_t done, uint64_t total) { seen.push_back({done, total}); };
    const MtModel m = MtModel::build(v, o);
    ASSERT_GT(m.updates().size(), 4096u);
    ASSERT_GE(seen.size(), 3u) << "no report between the start and the end";
    EXPECT_EQ(seen.front().done, 0u);
    for (size_t i = 1; i < seen.size(); ++i) {
        EXPECT_EQ(seen[i].total, seen.front().total);
        EXPECT_GE(seen[i].done, seen[i - 1].done) << "call " << i;
    }
    EXPECT_EQ(seen.back().done, seen.back().total);
    // The same model as without a callback.
    MtBuildOptions plain = o;
    plain.progress = nullptr;
    EXPECT_TRUE(encode_mt(m) == encode_mt(MtModel::build(v, plain)));
}
