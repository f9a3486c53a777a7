// Tet / data box classification (models/src/ht/tet_box.hpp): the quick
// answers (a vertex, the centroid or a point near a vertex strictly inside B)
// against the full separating-axis test on tets near B's faces, edges and
// corners, and both against points sampled in the tets.
#include <gtest/gtest.h>

#include <random>

#include "tet_box.hpp"

using namespace tetlod;
using namespace tetlod::ht;

namespace {

int64_t volume6(const Tet& t) {
    const int64_t a[3] = {t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]};
    const int64_t b[3] = {t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]};
    const int64_t c[3] = {t[3][0] - t[0][0], t[3][1] - t[0][1], t[3][2] - t[0][2]};
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/// Random non-degenerate tets whose vertices lie within 3 steps of a corner,
/// an edge or a face of B = [0, m], inside or out (never negative: HT tets are not).
Tet random_tet(std::mt19937& rng, const std::array<int32_t, 3>& m) {
    for (;;) {
        const int where = int(rng() % 3);  // per axis: near 0, near m, or anywhere
        int near[3];
        for (int a = 0; a < 3; ++a) near[a] = a == 0 ? where : int(rng() % 3);
        Tet t;
        for (auto& p : t)
            for (int a = 0; a < 3; ++a) {
                const int32_t off = int32_t(rng() % 7) - 3;
                p[a] = near[a] == 0 ? std::max(0, off + 1) : near[a] == 1 ? m[a] + off : int32_t(rng() % (m[a] + 4));
            }
        if (volume6(t) != 0) return t;
    }
}

}  // namespace

TEST(TetBox, QuickAnswersAgreeWithTheFullTest) {
    std::mt19937 rng(5);
    const std::array<int32_t, 3> m{10, 7, 12};
    const IBox box{{0, 0, 0}, {m[0], m[1], m[2]}};
    int counts[3] = {0, 0, 0};
    for (int i = 0; i < 200000; ++i) {
        const Tet t = random_tet(rng, m);
        bool inside = true;
        for (const Pt& p : t) inside = inside && p[0] <= m[0] && p[1] <= m[1] && p[2] <= m[2];
        const BoxRelation want = inside                           ? BoxRelation::Inside
                                 : tet_interior_meets_box(t, box) ? BoxRelation::Crossing
                                                                  : BoxRelation::Outside;
        const BoxRelation got = classify_against_data_box(t, m);
        ASSERT_EQ(int(got), int(want)) << i;
        ++counts[int(got)];
    }
    for (int c : counts) EXPECT_GT(c, 1000);  // every answer, often
}

TEST(TetBox, AgreesWithPointsSampledInTheTet) {
    // Independent of the axes: a sampled point of the closed tet strictly inside
    // B means the interiors meet (Crossing or Inside); Outside tets have none.
    std::mt19937 rng(9);
    const std::array<int32_t, 3> m{6, 9, 5};
    constexpr int kD = 12;  // barycentric coordinates in twelfths
    for (int i = 0; i < 4000; ++i) {
        const Tet t = random_tet(rng, m);
        bool witness = false;
        for (int a = 0; a <= kD && !witness; ++a)
            for (int b = 0; a + b <= kD && !witness; ++b)
                for (int c = 0; a + b + c <= kD && !witness; ++c) {
                    const int d = kD - a - b - c;
                    bool strictly = true;
                    for (int ax = 0; ax < 3; ++ax) {
                        const int64_t s = int64_t(a) * t[0][ax] + int64_t(b) * t[1][ax] + int64_t(c) * t[2][ax] +
                                          int64_t(d) * t[3][ax];  // kD x the point
                        strictly = strictly && s > 0 && s < int64_t(kD) * m[ax];
                    }
                    witness = strictly;
                }
        if (witness) EXPECT_NE(int(classify_against_data_box(t, m)), int(BoxRelation::Outside)) << i;
    }
}
