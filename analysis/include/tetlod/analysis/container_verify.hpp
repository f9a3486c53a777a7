#pragma once
// Verification of a .tlod container (`tetlod verify`): every checksum and
// structural rule; the MT decoded (labels, dependencies, errors and masks
// validated) and extracted; the HT decoded whole. Deep verification also
// recomputes, by brute force, the closed error of every HT tet in the data box
// and checks that its diamond's bound is at least it, plus E in a lossy file
// (ht_bound_check.hpp); for the MT it runs a full refinement, checks
// that its final mesh is the reference mesh (5 tets per cell) and that every tet
// on the way has a closed error (exact, recomputed from the decoded field by
// brute force, mt_bound_check.hpp) no larger than its creator's stored error,
// plus E in a lossy (LOSSY_MT) file (spec/mt-model.md §M4, spec §5.1).
//
// Safe on untrusted files: every problem becomes the report's `failure`
// (naming the file), never a crash; the only exception that escapes is
// std::bad_alloc when the machine runs out of memory.
#include <cstdint>
#include <optional>
#include <string>

#include "tetlod/core/error.hpp"

namespace tetlod {

/// How far verification got: each stage's fields are set once it passed.
/// `failure` holds the first problem; the stages after it did not run.
struct VerifyReport {
    std::string path;
    bool checksums_ok = false;  // header, table and every section's checksum
    uint64_t sections = 0;
    bool has_ht = false, has_mt = false;

    bool mt_ok = false;              // MT decoded and extracted at error 0
    uint64_t mt_updates = 0, mt_tets_at_error0 = 0;
    bool mt_deep_ok = false;         // deep: full mesh = reference mesh, every stored error holds
    uint64_t mt_reference_tets = 0;
    uint64_t mt_bounds_checked = 0;  // deep: tets of the full refinement compared with their bound
    uint64_t mt_bounds_unchecked = 0;  // deep: of a float field, tets with a non-finite value (skipped)
    double mt_worst_bound_ratio = 1;   // largest stored / (exact + E) over tets with exact + E > 0

    bool ht_ok = false;              // HT decoded: field and every chunk
    uint64_t ht_chunks_decoded = 0;
    bool ht_deep_ok = false;          // deep: every diamond bound >= its tets' exact errors + E
    uint64_t ht_bounds_checked = 0;   // deep: tets of the hierarchy in the data box compared with their bound
    uint64_t ht_bounds_unchecked = 0;  // deep: of a float field, tets with a non-finite value (skipped)
    double ht_worst_bound_ratio = 1;  // largest bound / (exact + E) over tets with exact + E > 0
    /// Format 3.1 lossy container: the stated bound E (0: lossless). Checked
    /// (finite, > 0, with the LOSSY feature) when the HT is read; with --deep,
    /// every decoded bound is >= its tets' exact errors + E.
    double max_error = 0;

    std::optional<Failure> failure;
    bool ok() const { return !failure.has_value(); }
};

VerifyReport verify_container(const std::string& path, bool deep);

}  // namespace tetlod
