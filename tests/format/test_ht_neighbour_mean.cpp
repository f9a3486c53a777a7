// The neighbour mean of the HT coders' contexts (spec §7.6) divides by a
// multiply with a reciprocal below 2^26 (ht_prediction.hpp): exact for every
// dividend there and every count of neighbours (1..9), checked exhaustively,
// and the lattice's mean agrees with the definition on sums across the limit.
#include <gtest/gtest.h>

#include <vector>

#include "ht_prediction.hpp"

using tetlod::ht_detail::LatticeView;

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
    const uint64_t mags[] = {0, 1, 7, (1u << 26) / 9, (1u << 26) / 9 + 1, (1u << 26) - 1, 1u << 26,
                             0xFFFFFFFEu};
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
