// The refinement's point table (BlockedPointMap) against std::map: random
// points and values, replacements, misses, growth at every coordinate size;
// and under concurrent writers, exactly one winner per claimed point.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <random>
#include <thread>
#include <vector>

#include "tetlod/models/detail/blocked_point_map.hpp"

namespace {

using Point = tetlod::detail::BlockedPointMap::Point;

/// Random points (from `point`) and values into `m` and a std::map, the
/// corners of the coordinate range too; then every stored point and as many
/// random probes must agree.
template <class Map, class MakePoint>
void check_map(Map& m, int64_t max_coordinate, uint32_t max_value, int n, std::mt19937_64& rng, MakePoint point) {
    std::map<Point, uint32_t> want;
    for (int i = 0; i < n; ++i) {
        const Point p = point();
        const uint32_t v = uint32_t(rng() % (uint64_t(max_value) + 1));
        m.put(p, v);
        want[p] = v;
    }
    for (int c = 0; c < 8; ++c) {
        const Point p{(c & 1) ? int32_t(max_coordinate) : 0, (c & 2) ? int32_t(max_coordinate) : 0,
                      (c & 4) ? int32_t(max_coordinate) : 0};
        m.put(p, max_value);
        want[p] = max_value;
    }
    ASSERT_EQ(m.size(), want.size());
    for (const auto& [p, v] : want) {
        uint32_t got = 0;
        ASSERT_TRUE(m.find(p, got)) << p[0] << "," << p[1] << "," << p[2];
        ASSERT_EQ(got, v);
    }
    for (int i = 0; i < n; ++i) {
        const Point p = point();
        uint32_t got = 0;
        ASSERT_EQ(m.find(p, got), want.count(p) == 1) << p[0] << "," << p[1] << "," << p[2];
    }
}

}  // namespace

// ---- BlockedPointMap: the same contract, with blocks per cycle lattice ----

namespace {

void check_blocked(int64_t max_coordinate, uint32_t max_value, int n, unsigned seed, bool clustered) {
    tetlod::detail::BlockedPointMap m(max_coordinate);
    std::mt19937_64 rng(seed);
    auto coord = [&] { return int32_t(rng() % uint64_t(max_coordinate + 1)); };
    check_map(m, max_coordinate, max_value, n, rng, [&] {
        if (!clustered) return Point{coord(), coord(), coord()};
        // A point of a random cycle near a random centre: dense blocks and
        // points of every cycle sharing coordinates' high bits.
        const int t = int(rng() % 6);
        Point p;
        for (auto& c : p) {
            const int64_t v = (int64_t(coord()) & ~((int64_t{1} << t) - 1)) & ~int64_t{0xFF};
            c = int32_t(std::min<int64_t>(max_coordinate, v + int64_t(rng() % 8) * (int64_t{1} << t)));
        }
        return p;
    });
}

}  // namespace

TEST(BlockedPointMap, AgreesWithStdMapAtEveryCoordinateSize) {
    for (int64_t maxc : {int64_t{1}, int64_t{2}, int64_t{3}, int64_t{16}, int64_t{256}, int64_t{1025}, int64_t{65536}, int64_t{1} << 20})
        for (uint32_t maxv : {1u, 1000u, 0x7FFFFFFFu, 0xFFFFFFFEu})
            for (bool clustered : {false, true}) check_blocked(maxc, maxv, 20000, unsigned(maxc + maxv) + clustered, clustered);
}

TEST(BlockedPointMap, MemoryFollowsBlocksTouched) {
    // A dense 32^3 box of cycle-0 lattice points fills its blocks: a few bytes per point.
    tetlod::detail::BlockedPointMap dense(1024);
    for (int32_t z = 0; z < 32; ++z)
        for (int32_t y = 0; y < 32; ++y)
            for (int32_t x = 0; x < 32; ++x) dense.put({x, y, z}, uint32_t(x + y + z));
    EXPECT_EQ(dense.size(), 32u * 32 * 32);
    // A page of 272 KiB, one leaf, and the leaf table sized for every leaf a
    // 1025^3 grid can have (2 MiB of virtual memory, touched where used).
    EXPECT_LT(dense.memory_bytes(), std::size_t{3} << 20);
    uint32_t v = 0;
    EXPECT_TRUE(dense.find({31, 31, 31}, v));
    EXPECT_EQ(v, 93u);
    EXPECT_FALSE(dense.find({32, 0, 0}, v));
}

TEST(BlockedPointMap, ConcurrentWritersAgreeWithOneThread) {
    // Four threads claim (set_bit0) and store values at overlapping clustered
    // points of every cycle: each point is won by exactly one claim, every
    // value stored is found, and enumeration sees each point once.
    constexpr int kThreads = 4, kPerThread = 60000;
    const int64_t maxc = 1024;
    tetlod::detail::BlockedPointMap m(maxc);
    std::vector<std::vector<Point>> points(kThreads);
    std::mt19937_64 rng(7);
    for (auto& ps : points)
        for (int i = 0; i < kPerThread; ++i) {
            const int t = int(rng() % 5);
            Point p;
            for (auto& c : p) c = int32_t(std::min<int64_t>(maxc, int64_t(rng() % 64) << t));
            ps.push_back(p);
        }
    std::vector<std::vector<Point>> won(kThreads);
    std::vector<std::thread> threads;
    for (int k = 0; k < kThreads; ++k)
        threads.emplace_back([&, k] {
            for (const Point& p : points[std::size_t(k)])
                if (m.set_bit0(p)) won[std::size_t(k)].push_back(p);
        });
    for (auto& t : threads) t.join();
    std::map<Point, int> claims;
    for (const auto& w : won)
        for (const Point& p : w) ++claims[p];
    std::map<Point, int> distinct;
    for (const auto& ps : points)
        for (const Point& p : ps) distinct[p] = 1;
    ASSERT_EQ(claims.size(), distinct.size());
    for (const auto& [p, n] : claims) ASSERT_EQ(n, 1) << p[0] << "," << p[1] << "," << p[2];
    // Values written concurrently by the point's winner: id << 1 | 1.
    threads.clear();
    for (int k = 0; k < kThreads; ++k)
        threads.emplace_back([&, k] {
            for (const Point& p : won[std::size_t(k)]) m.put(p, uint32_t((p[0] + 3 * p[1] + 5 * p[2]) << 1 | 1));
        });
    for (auto& t : threads) t.join();
    std::size_t seen = 0;
    m.for_each([&](const Point& p, uint32_t v) {
        ++seen;
        ASSERT_EQ(v, uint32_t((p[0] + 3 * p[1] + 5 * p[2]) << 1 | 1));
    });
    EXPECT_EQ(seen, distinct.size());
    uint32_t v = 0;
    for (const auto& [p, n] : distinct) {
        ASSERT_TRUE(m.find(p, v));
        ASSERT_FALSE(m.set_bit0(p));  // already claimed
    }
}
