#pragma once
// The default shape cap of the MT build: no collapse may create a tet whose
// circumradius / shortest edge ratio (physical coordinates; regular tet 0.61, the
// reference mesh's cell tets 0.61 and 0.87) exceeds it.
//
// Why 6: measured on the seven real volumes of the test data at uniform LODs of 0.1 to
// 10 % of the range (bench/bench_mt_shapes, docs/mt.md §6), an uncapped build leaves
// slivers of ratio 28 to 1024; a cap of 10 costs at most 4 % more tets, 6 at most 9 %,
// 5 up to 19 % and 4 up to 27 %. 6 is the tightest cap within 15 % more tets on every
// volume and LOD. The mean ratio is a separate matter: a cap alone does not bring it
// to the paper's 1.3-1.4 at coarse LODs (1.6-2.1 at 10 % with a cap of 6).
namespace tetlod {

inline constexpr double kDefaultMtMaxShapeRatio = 6.0;

}  // namespace tetlod
