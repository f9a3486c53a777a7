#pragma once
// Brute-force check of an HT's decoded diamond error bounds (spec/tlod-format.md §2,
// "Diamond error", §8; lossy files §5.1): for every tet of the bisection hierarchy
// (spec/ht-model.md §H1) below the unit level whose centre lies in the data box B,
// the bound of its diamond must be
//  - +inf when the tet crosses a face of B (the diamond's error is +inf: it must
//    always split), and
//  - >= the tet's closed error + E when the tet lies in B, where the closed error is
//    max |f'(p) - L_T(p)| over the grid points p of the closed tet, f' the decoded
//    field, and E the file's field.max_error (0 when lossless). The diamond error is
//    the maximum over its tets, so this is "bound >= diamond error + E": the stated
//    bound holds against the original at every grid point (|L_T - f| <=
//    |L_T - f'| + E).
// Tets whose open interior misses B are not part of any query's mesh and bound nothing.
//
// Independent of what it checks: the hierarchy is generated here from the spec's
// bisection rule (roots, tags, children), inside / crossing / outside decided by an
// exact separating-axis test, and the closed errors recomputed by exact grid geometry
// (exact_tet_error.hpp); nothing is shared with models/ (HtModel::build and its error
// sweep) or codecs/ beyond the decoded arrays given. Comparisons are exact, as the
// MT's (mt_bound_check.hpp).
//
// Cost: every tet of the hierarchy meeting B, about 12 per grid point of B, and its
// grid points (about 3k + 3 per grid point over all levels); the subtrees run on the
// TBB threads and the result does not depend on how many.
#include <array>
#include <cstdint>
#include <optional>
#include <span>

#include "tetlod/core/volume.hpp"

namespace tetlod {

/// The first tet (in the hierarchy's depth-first order from the roots, children
/// in bisection order) whose diamond's bound fails.
struct HtBoundViolation {
    std::array<int64_t, 3> centre{};               // the diamond's centre
    int level = 0;                                 // the tet's (and the diamond's) level
    std::array<std::array<int64_t, 3>, 4> tet{};  // its corners
    bool crossing = false;                         // crosses a face of B: the bound must be +inf
    double stored = 0;                             // the decoded bound (E included)
    double exact = 0;                              // the tet's closed error against f' (+inf: crossing)
    int64_t at = 0;                                // grid index of a point where |f' - L_T| is largest
};

struct HtBoundCheck {
    uint64_t tets_checked = 0;       // tets in B compared with their diamond's bound
    uint64_t crossing_tets = 0;      // tets crossing a face of B, centre in B (bound must be +inf)
    uint64_t nonfinite_tets = 0;     // of a float field, tets with a non-finite value: not checked
    uint64_t points_visited = 0;     // (tet, grid point) pairs evaluated
    uint64_t exact_comparisons = 0;  // comparisons the double filter could not decide
    /// Largest bound / (exact + E) over checked tets with a finite bound and exact + E > 0.
    double worst_ratio = 1;
    uint64_t violations = 0;
    std::optional<HtBoundViolation> first;
    bool ok() const { return violations == 0; }
};

/// `field`: f' on B = [0, box_max] (the decoded HT field; padded: the cube), `k`:
/// the cube is [0, 2^k]^3; `bounds`: the decoded bound of every grid point of B
/// (field's raster order, E included as spec §5.1 says); `field_error`: E (0 when
/// lossless). Throws tetlod::Error(InvalidArgument) when the sizes disagree (field
/// dims != box_max + 1, bounds size, a box outside the cube) or E is negative or
/// not finite.
HtBoundCheck check_ht_bounds(const Volume& field, int k, const std::array<int64_t, 3>& box_max,
                             std::span<const float> bounds, double field_error = 0);

}  // namespace tetlod
