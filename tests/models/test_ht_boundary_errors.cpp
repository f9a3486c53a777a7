// The exact diamond errors of compute_diamond_errors (templates inside the
// data box, span templates per tet for the diamonds at its faces) against the
// plain per-tet scan of ErrorBuilder::diamond_error, centre by centre, as
// floats: the encoder quantizes errors to a few mantissa bits, so a container
// comparison alone would not see a small difference. Boxes of odd sizes
// (not 2^k + 1) put many diamonds of every templated level at the faces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "ht_error_build.hpp"
#include "ht_error_builder.hpp"
#include "tetlod/models/ht/ht_model.hpp"

namespace tetlod::ht {
namespace {

using namespace error_detail;

template <class T>
Volume smooth_and_noisy(Dims dims, ValueType type, uint32_t seed) {
    Volume v = Volume::allocate(dims, type);
    std::mt19937 rng(seed);
    T* p = v.as<T>();
    const double lo = std::is_integral_v<T> ? double(std::numeric_limits<T>::min()) : -1000.0;
    const double hi = std::is_integral_v<T> ? double(std::numeric_limits<T>::max()) : 1000.0;
    for (int64_t z = 0; z < dims.z; ++z)
        for (int64_t y = 0; y < dims.y; ++y)
            for (int64_t x = 0; x < dims.x; ++x) {
                // A smooth ramp plus noise, spanning much of the type's range.
                const double s = 0.5 + 0.25 * std::sin(0.21 * double(x) + 0.13 * double(y * z % 17));
                const double n = double(rng() % 2001) / 2000.0 - 0.5;
                const double f = std::clamp(lo + (hi - lo) * (s + 0.2 * n), lo, hi);
                *p++ = T(f);
            }
    return v;
}

template <class T>
void expect_scan_equal(Dims dims, ValueType type) {
    const Volume field = smooth_and_noisy<T>(dims, type, uint32_t(dims.x * 131 + dims.y * 7 + dims.z));
    const HtDomain d = HtDomain::for_dims(dims, false);
    const ZeroedVector<float> errors = compute_diamond_errors(field, d);
    int64_t compared = 0, infinite = 0, mismatches = 0;
    std::string first;
    with_accumulator<T>(d, field.range(), [&](auto acc, double slack) {
        using Acc = decltype(acc);
        const ErrorBuilder<T, Acc> eb(field.as<T>(), 0, dims.x, dims.x * dims.y, d);
        for (int level = 0; level < d.max_level(); ++level)
            eb.for_level_centres(
                level, 0, d.box_max[2],
                [&](const Pt& c) {
                    const float want = eb.round_up(eb.diamond_error(c, classify_centre(c, d.k)), slack);
                    const float got = errors[std::size_t(eb.index(c))];
                    if (std::memcmp(&want, &got, sizeof(float)) != 0 && mismatches++ == 0)
                        first = "level " + std::to_string(level) + " centre " + std::to_string(c[0]) + "," +
                                std::to_string(c[1]) + "," + std::to_string(c[2]) + ": " + std::to_string(got) +
                                " instead of " + std::to_string(want);
                    ++compared;
                    infinite += std::isinf(want) ? 1 : 0;
                },
                false);
    });
    EXPECT_EQ(mismatches, 0) << "first: " << first;
    // Every grid point of B is a centre but the cube's corners (multiples of L).
    int64_t corners = 1;
    for (int a = 0; a < 3; ++a) corners *= d.box_max[a] / d.L + 1;
    EXPECT_EQ(compared, d.dims().count() - corners);
    EXPECT_GT(compared - infinite, 0);
}

TEST(HtBoundaryErrors, U8MatchesThePerTetScan) { expect_scan_equal<uint8_t>({45, 37, 52}, ValueType::U8); }
TEST(HtBoundaryErrors, U8SpanLevelH8) { expect_scan_equal<uint8_t>({100, 71, 83}, ValueType::U8); }
TEST(HtBoundaryErrors, U8SpanLevelH16) { expect_scan_equal<uint8_t>({140, 21, 30}, ValueType::U8); }
TEST(HtBoundaryErrors, I16MatchesThePerTetScan) { expect_scan_equal<int16_t>({70, 33, 41}, ValueType::I16); }
TEST(HtBoundaryErrors, U16MatchesThePerTetScan) { expect_scan_equal<uint16_t>({29, 66, 40}, ValueType::U16); }
TEST(HtBoundaryErrors, I32KeepsTheScan) { expect_scan_equal<int32_t>({30, 21, 44}, ValueType::I32); }
TEST(HtBoundaryErrors, F32KeepsTheScan) { expect_scan_equal<float>({26, 35, 19}, ValueType::F32); }

}  // namespace
}  // namespace tetlod::ht
