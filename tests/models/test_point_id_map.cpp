// The refinement's point tables (PointIdMap, BlockedPointMap) against std::map: random points and values,
// replacements, misses, growth, the packed layout at every coordinate size,
// and the switch to the wide layout when a value outgrows the packed field.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>

#include "tetlod/models/detail/blocked_point_map.hpp"
#include "tetlod/models/detail/point_id_map.hpp"

using tetlod::detail::PointIdMap;

namespace {

using Point = PointIdMap::Point;

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

void check(int64_t max_coordinate, uint32_t max_value, int n, unsigned seed) {
    PointIdMap m(max_coordinate);
    std::mt19937_64 rng(seed);
    auto coord = [&] { return int32_t(rng() % uint64_t(max_coordinate + 1)); };
    check_map(m, max_coordinate, max_value, n, rng, [&] { return Point{coord(), coord(), coord()}; });
}

TEST(PointIdMap, AgreesWithStdMapAtEveryCoordinateSize) {
    for (int64_t maxc : {int64_t{1}, int64_t{2}, int64_t{3}, int64_t{16}, int64_t{256}, int64_t{1024}, int64_t{2048}, int64_t{65536}, int64_t{1} << 20})
        for (uint32_t maxv : {1u, 1000u, 0x7FFFFFFFu, 0xFFFFFFFFu}) check(maxc, maxv, 20000, unsigned(maxc + maxv));
}

TEST(PointIdMap, PackedUntilAValueOutgrowsIt) {
    PointIdMap m(1024);  // 12 bits per axis: 28 bits for values
    EXPECT_TRUE(m.packed());
    for (int32_t i = 0; i < 5000; ++i) m.put({i % 1000, i / 1000, 7}, uint32_t(i));
    EXPECT_TRUE(m.packed());
    m.put({5, 5, 5}, uint32_t{1} << 30);
    EXPECT_FALSE(m.packed());
    uint32_t v = 0;
    for (int32_t i = 0; i < 5000; ++i) {
        ASSERT_TRUE(m.find({i % 1000, i / 1000, 7}, v));
        ASSERT_EQ(v, uint32_t(i));
    }
    ASSERT_TRUE(m.find({5, 5, 5}, v));
    EXPECT_EQ(v, uint32_t{1} << 30);
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
    EXPECT_LT(dense.memory_bytes(), std::size_t{2} << 20);  // pages of 256 KiB + small tables
    uint32_t v = 0;
    EXPECT_TRUE(dense.find({31, 31, 31}, v));
    EXPECT_EQ(v, 93u);
    EXPECT_FALSE(dense.find({32, 0, 0}, v));
}
