// The neighbour mean of the HT coders' contexts (spec §7.6) divides by a
// multiply with a reciprocal below 2^26 (ht_prediction.hpp): exact for every
// dividend there and every count of neighbours (1..9), checked exhaustively,
// and the lattice's mean agrees with the definition on sums across the limit.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "ht_chunk_rows.hpp"

using tetlod::ht_detail::LatticeView;

namespace {

/// f(t, box, lat) for chunks of every cycle of a 33^3 data box: the whole box,
/// small and odd-origin boxes, and boxes on the faces of B, each with a fresh
/// (all unset) lattice.
template <class F>
void for_each_test_chunk(const tetlod::ht_detail::Geometry& G, F&& f) {
    const std::array<int64_t, 6> boxes[] = {{0, 0, 0, 32, 32, 32},
                                            {0, 0, 0, 7, 7, 7},
                                            {8, 16, 0, 15, 23, 7},
                                            {3, 5, 7, 30, 29, 31},
                                            {16, 16, 16, 32, 32, 32}};
    for (int t = 0; t < G.k; ++t)
        for (const auto& box : boxes) {
            std::vector<uint32_t> storage;
            tetlod::ht_detail::ChunkLattice lat(t, box, storage);
            f(t, box, lat);
        }
}

tetlod::ht_detail::Geometry test_geometry() {
    tetlod::ht_detail::Geometry G;
    G.k = 5;
    G.g = 1;
    G.box_max = {32, 32, 32};
    return G;
}

/// A magnitude as a coder sets them: a quarter zeros, most small, some beyond
/// the reciprocal's limit.
uint64_t next_magnitude(uint64_t& rng) {
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;
    return (rng >> 60) < 4 ? 0 : (rng >> 33) % ((rng >> 62) == 3 ? (1u << 27) : 300);
}

}  // namespace

TEST(NeighbourMean, ReciprocalEqualsDivisionForEveryDividendBelowTheLimit) {
    for (uint64_t n = 1; n <= 9; ++n) {
        const uint64_t r = LatticeView::kReciprocal[n];
        uint64_t bad = 0;
        for (uint64_t x = 0; x < LatticeView::kReciprocalLimit; ++x)
            bad += ((x * r) >> LatticeView::kReciprocalShift) != x / n;
        EXPECT_EQ(bad, 0u) << "n = " << n;
    }
}

TEST(NeighbourMean, MatchesTheDefinitionAcrossTheLimit) {
    // A lattice of 5 x 5 x 5 slots; the point at the centre, its 9 neighbours
    // of spec §7.6 set to chosen magnitudes (stored + 1; 0 = unset).
    const int64_t px = 5, pxy = 25, s = 2 * pxy + 2 * px + 2;
    const int64_t nbr[9] = {-1, 1, -px, px, -pxy, pxy, -2, -2 * px, -2 * pxy};
    const uint64_t mags[] = {
        0, 1, 7, (1u << 26) / 9, (1u << 26) / 9 + 1, (1u << 26) - 1, 1u << 26, 0xFFFFFFFEu};
    for (int count = 0; count <= 9; ++count)
        for (uint64_t m : mags) {
            std::vector<uint32_t> lattice(125, 0);
            LatticeView v{lattice.data(), px, pxy};
            uint64_t sum = 0;
            for (int i = 0; i < count; ++i) {
                const uint64_t mi = m + uint64_t(i);
                v.set(s + nbr[i], mi);
                sum += std::min<uint64_t>(mi, 0xFFFFFFFEu);
            }
            const uint64_t want = count == 0 ? 0 : sum / uint64_t(count);
            EXPECT_EQ(v.neighbour_mean(s), want) << "count " << count << " magnitude " << m;
        }
}

TEST(NeighbourMean, InCodingOrderEqualsTheFullMeanOnEveryPoint) {
    // neighbour_mean_in_order reads only the neighbours a point of class 0..2
    // can have set when coding order 2 reaches it: walk chunks of several
    // cycles and boxes (interior, on the faces of B, odd origins) in that order,
    // set random magnitudes as a coder does, and compare with the full mean
    // at every point before setting it.
    using namespace tetlod::ht_detail;
    const Geometry G = test_geometry();
    uint64_t rng = 12345, points = 0;
    for_each_test_chunk(G, [&](int t, const std::array<int64_t, 6>& box, const ChunkLattice& lat) {
        const LatticeView v = lat.view();
        uint64_t mismatches = 0;
        for_each_row_v2(G, t, box, [&](const ChunkRow& r) {
            const RowEvenStrides e = row_even_strides(r, v);
            for (int64_t x = r.x0; x <= r.x1; x += r.step) {
                const int64_t s = lat.slot(x, r.y, r.z);
                mismatches +=
                    v.neighbour_mean_in_order(r.cls, s, e.even1, e.even2) != v.neighbour_mean(s);
                v.set(s, next_magnitude(rng));
                ++points;
            }
        });
        EXPECT_EQ(mismatches, 0u) << "cycle " << t << " box " << box[0] << "," << box[1] << ","
                                  << box[2];
    });
    EXPECT_GT(points, 10000u);
}

TEST(NeighbourMean, RowTwoPassSplitEqualsTheFullMeanOnEveryPoint) {
    // The field decoder (decode_field_rows) works out, for a whole row before
    // decoding it, the context part of every point other than the previous
    // point of the row (others_in_order), and carries that previous point's
    // lattice value in a register (mean_with_prev). That gives the full mean
    // only if nothing the row sets is among the others and the slot two
    // before a point is the previous point's: checked at every point, in
    // coding order, with random magnitudes set as a coder does.
    using namespace tetlod::ht_detail;
    const Geometry G = test_geometry();
    uint64_t rng = 987654321, points = 0;
    for_each_test_chunk(G, [&](int t, const std::array<int64_t, 6>& box, const ChunkLattice& lat) {
        const LatticeView v = lat.view();
        uint64_t mismatches = 0;
        for_each_row_v2(G, t, box, [&](const ChunkRow& r) {
            if (r.cls == 3) return;  // corners: the full mean, no split
            const RowEvenStrides e = row_even_strides(r, v);
            std::vector<LatticeView::Others> others;
            for (int64_t x = r.x0; x <= r.x1; x += r.step)
                others.push_back(v.others_in_order(r.cls, lat.slot(x, r.y, r.z), e.even1, e.even2));
            uint32_t wprev = v.mag[lat.slot(r.x0, r.y, r.z) - 2];
            std::size_t i = 0;
            for (int64_t x = r.x0; x <= r.x1; x += r.step, ++i) {
                const int64_t s = lat.slot(x, r.y, r.z);
                mismatches += LatticeView::mean_with_prev(others[i], wprev) != v.neighbour_mean(s);
                mismatches += v.neighbour_mean_in_order_prev(r.cls, s, e.even1, e.even2, wprev) !=
                              v.neighbour_mean(s);
                const uint64_t m = next_magnitude(rng);
                v.set(s, m);
                wprev = LatticeView::stored(m);
                ++points;
            }
        });
        EXPECT_EQ(mismatches, 0u) << "cycle " << t << " box " << box[0] << "," << box[1] << ","
                                  << box[2];
    });
    EXPECT_GT(points, 10000u);
}
