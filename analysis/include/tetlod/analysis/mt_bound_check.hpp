#pragma once
// Brute-force check of an MT's stored update errors (spec/mt-model.md §M4, "Error
// meaning"): for every tet T of every mesh a full refinement passes through (the
// base mesh's tets and every tet each split creates), the current update of T's
// creator must have an error >= the closed error of T, max |f(p) - L_T(p)| over
// the grid points p of the closed tet. Beside a lossy HT (spec/tlod-format.md §5.1,
// LOSSY_MT) the stored error must be >= that error against the stored field f'
// plus E, the file's field.max_error. A reference tet (no creator) must have
// closed error 0 (§M2).
//
// Independent of what it checks: the tets come from the model's own refinement
// (MtModel::extract_visiting), but the closed errors are recomputed here from the
// field by exact grid geometry (barycentric numerators in 64-bit integers, every
// grid point of the closed tet visited row by row), sharing no code with the MT
// builder's error evaluation. Comparisons are exact: integer fields in 64/128-bit
// integers, float fields in double with a rigorous error bound, decided exactly
// (floating-point expansions) when the bound is too loose to tell.
//
// Cost: one full refinement (memory and time of `extract --full`) plus, per
// visited tet, its grid points (on the bench volumes about 33 tets per grid
// point, about 7 grid points each). The check of one buffer of tets runs on a
// TBB thread while the refinement produces the next; the result does not depend
// on the threads.
//
// Safe on any model from_parts accepted (a decoded, untrusted one): a model found
// inconsistent during the refinement throws CorruptData, never crashes. The work is
// not bounded beyond what the refinement bounds (tets at once, pops): a hostile model
// whose splits keep creating large tets costs time quadratic in the grid points.
#include <array>
#include <cstdint>
#include <optional>

#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

/// The first tet found whose creator's stored error is below its closed error.
struct MtBoundViolation {
    std::array<uint32_t, 4> tet{};  // grid indices
    uint32_t creator = MtVisitedTet::kNone;  // grid index of the creator (the update's survivor s); kNone: a reference tet
    uint32_t inserts = 0;           // the update's w (creator only)
    uint32_t label = 0;             // the update's label (creator only)
    double stored = 0;              // the update's error (0 for a reference tet)
    double exact = 0;               // closed error against the model's field (approximate to ~1e-15 for floats)
    uint32_t at = 0;                // grid index of a point where |f - L_T| is largest
};

struct MtBoundCheck {
    uint64_t full_mesh_tets = 0;     // tets of the full refinement's final mesh
    uint64_t tets_checked = 0;       // visited tets compared with their bound (reference tets included)
    uint64_t nonfinite_tets = 0;     // visited tets with a non-finite value at a grid point: not checked
    uint64_t points_visited = 0;     // (tet, grid point) pairs evaluated
    uint64_t exact_comparisons = 0;  // comparisons the double filter could not decide (per point: floats; per tet: integers)
    /// Largest stored / (exact + E) over the tets with a creator and exact + E > 0
    /// (lossless: E = 0, so over nonzero exact errors); 1 when there is none.
    double worst_ratio = 1;
    uint64_t violations = 0;         // tets whose bound does not hold
    std::optional<MtBoundViolation> first;
    bool ok() const { return violations == 0; }
};

/// Checks every update error of `mt` against the closed errors of the tets it
/// bounds, in a full refinement. `field_error` is E of a LOSSY_MT container (the
/// stored update errors must be >= exact + E, in exact arithmetic), 0 otherwise.
/// Throws tetlod::Error(CorruptData) when the refinement finds the model
/// inconsistent, InvalidArgument when field_error is negative or not finite.
MtBoundCheck check_mt_bounds(const MtModel& mt, double field_error = 0);

}  // namespace tetlod
