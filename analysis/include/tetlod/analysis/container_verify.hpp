#pragma once
// Verification of a .tlod container (`tetlod verify`): every checksum and
// structural rule; the MT decoded (labels, dependencies, errors and masks
// validated) and extracted; the HT decoded whole. Deep verification also
// recomputes every exact diamond error from the decoded field and checks that
// each stored bound is at least it, and that the MT's full mesh is the
// reference mesh (5 tets per cell).
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
    bool mt_deep_ok = false;         // deep: full mesh = reference mesh
    uint64_t mt_reference_tets = 0;

    bool ht_ok = false;              // HT decoded: field and every chunk
    uint64_t ht_chunks_decoded = 0;
    bool ht_deep_ok = false;         // deep: every stored bound >= exact error
    uint64_t ht_bounds_checked = 0;
    double ht_worst_bound_ratio = 1;  // largest stored / exact over nonzero errors
    /// Format 3.1 lossy container: the stated bound E (0: lossless). Checked
    /// (finite, > 0, with the LOSSY feature) when the HT is read; with --deep,
    /// every finite decoded bound is >= E as well.
    double max_error = 0;

    std::optional<Failure> failure;
    bool ok() const { return !failure.has_value(); }
};

VerifyReport verify_container(const std::string& path, bool deep);

}  // namespace tetlod
