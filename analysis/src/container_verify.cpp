// Verification of a .tlod container (see container_verify.hpp). Each stage
// records what it established before the next runs, so a caller can report
// exactly how far a damaged file got.
#include "tetlod/analysis/container_verify.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>

#include "tetlod/analysis/ht_bound_check.hpp"
#include "tetlod/analysis/mt_bound_check.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

namespace {

/// Enough digits to show a float bound and an exact error apart.
std::string precise_text(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char b[40];
    std::snprintf(b, sizeof b, "%.9g", v);
    return b;
}

std::string point_text(uint32_t g, const Dims& d) {
    const int64_t i = g;
    return "(" + std::to_string(i % d.x) + "," + std::to_string(i / d.x % d.y) + "," +
           std::to_string(i / (d.x * d.y)) + ")";
}

// Throws tetlod::Error for a failed Expected (turned into the report's failure).
template <class T>
T take(Expected<T> e) {
    return e.take();
}

void verify_mt(const std::string& path, bool deep, VerifyReport& rep) {
    auto r = take(tlod::ContainerReader::open(path));
    // A LOSSY_MT file's E: its update errors must include it (spec §5.1).
    double field_error = 0;
    if (r.header().required_features & tlod::kFeatureHt) field_error = take(read_ht_layout(r)).max_error;
    const MtModel mt = take(decode_mt_container(r));
    LodQuery q;
    q.error_in = 0.0;
    const TetMesh m0 = mt.extract(q);  // throws CorruptData on an inconsistent MT
    rep.mt_updates = mt.updates().size();
    rep.mt_tets_at_error0 = m0.tet_count();
    rep.mt_ok = true;
    if (!deep) return;
    // One full refinement: its final mesh must be the reference mesh, and every tet
    // on the way must honour its creator's stored error (spec/mt-model.md §M4).
    const MtBoundCheck b = check_mt_bounds(mt, field_error);
    const Dims dd = mt.field().dims;
    const uint64_t want = 5 * uint64_t(dd.x - 1) * uint64_t(dd.y - 1) * uint64_t(dd.z - 1);
    const uint64_t got = b.full_mesh_tets;
    if (got != want)
        throw Error(ErrorCode::CorruptData, path + ": the MT's full mesh has " + std::to_string(got) +
                                                " tets, the reference mesh " + std::to_string(want));
    rep.mt_reference_tets = want;
    if (!b.ok()) {
        const MtBoundViolation& v = *b.first;
        std::string what;
        if (v.creator == MtVisitedTet::kNone) {
            what = "a reference tet (no creator, bound 0)";
        } else {
            what = "the update at " + point_text(v.creator, dd) + " label " + std::to_string(v.label) +
                   " (inserting " + point_text(v.inserts, dd) + ")";
        }
        std::string tet;
        for (int i = 0; i < 4; ++i) tet += (i ? " " : "") + point_text(v.tet[i], dd);
        throw Error(ErrorCode::CorruptData,
                    path + ": " + std::to_string(b.violations) +
                        " MT tets have a closed error above their creator's stored error (first: " + what +
                        ", tet " + tet + ": stored " + precise_text(v.stored) + ", exact " +
                        precise_text(v.exact) +
                        (field_error > 0 && v.creator != MtVisitedTet::kNone
                             ? " + E " + precise_text(field_error) + " (the file is lossy)"
                             : std::string()) +
                        ", largest at " + point_text(v.at, dd) + ")");
    }
    rep.mt_bounds_checked = b.tets_checked;
    rep.mt_bounds_unchecked = b.nonfinite_tets;
    rep.mt_worst_bound_ratio = b.worst_ratio;
    rep.mt_deep_ok = true;
}

// Every diamond's decoded bound must be at least the closed error of each of its tets
// in B recomputed by brute force from the decoded field, plus E in a lossy file, and
// +inf for a diamond with a tet crossing a face of B (ht_bound_check.hpp: the
// hierarchy generated from the spec, exact comparisons, no code of the builder).
void verify_ht_bounds(const std::string& path, HtDecoded& d, VerifyReport& rep) {
    const HtDomain& dom = d.layout.domain;
    const std::array<int64_t, 3> box{dom.box_max[0], dom.box_max[1], dom.box_max[2]};
    const HtBoundCheck b = check_ht_bounds(d.field, dom.k, box, std::span<const float>(d.errors.data(), d.errors.size()),
                                           d.layout.max_error);
    if (!b.ok()) {
        const HtBoundViolation& v = *b.first;
        const Dims dd = d.field.dims;
        std::string tet;
        for (int i = 0; i < 4; ++i)
            tet += (i ? " " : "") + std::string("(") + std::to_string(v.tet[i][0]) + "," + std::to_string(v.tet[i][1]) +
                   "," + std::to_string(v.tet[i][2]) + ")";
        const std::string centre =
            "(" + std::to_string(v.centre[0]) + "," + std::to_string(v.centre[1]) + "," + std::to_string(v.centre[2]) + ")";
        const double E = d.layout.max_error;
        throw Error(ErrorCode::CorruptData,
                    path + ": " + std::to_string(b.violations) + " HT tets have a closed error above their diamond's bound (first: the diamond at " + centre +
                        " level " + std::to_string(v.level) + ", tet " + tet + ": " +
                        (v.crossing ? "the tet crosses a face of the data box, so the bound must be +inf; stored " +
                                          precise_text(v.stored)
                                    : "stored " + precise_text(v.stored) + ", exact " + precise_text(v.exact) +
                                          (E > 0 ? " + E " + precise_text(E) + " (the file is lossy)" : std::string()) +
                                          ", largest at " + point_text(uint32_t(v.at), dd)) +
                        ")");
    }
    rep.ht_bounds_checked = b.tets_checked;
    rep.ht_bounds_unchecked = b.nonfinite_tets;
    rep.ht_worst_bound_ratio = b.worst_ratio;
    rep.ht_deep_ok = true;
}

void verify(const std::string& path, bool deep, VerifyReport& rep) {
    auto r = take(tlod::ContainerReader::open(path));
    // Checksums of every section, known or not.
    for (std::size_t i = 0; i < r.sections().size(); ++i) take(r.read_stored(i));
    rep.sections = r.sections().size();
    rep.checksums_ok = true;
    rep.has_ht = (r.header().required_features & tlod::kFeatureHt) != 0;
    rep.has_mt = container_has_mt(r);
    if (!rep.has_ht && !rep.has_mt) throw Error(ErrorCode::NotFound, path + ": the container holds no model");
    if (rep.has_mt) verify_mt(path, deep, rep);
    if (!rep.has_ht) return;
    // Structure, frames, sizes and code ranges: decode everything.
    HtDecoded d = take(decode_ht(r));
    rep.ht_chunks_decoded = d.chunks_decoded;
    rep.max_error = d.layout.max_error;
    rep.ht_ok = true;
    if (deep) verify_ht_bounds(path, d, rep);
}

}  // namespace

VerifyReport verify_container(const std::string& path, bool deep) {
    VerifyReport rep;
    rep.path = path;
    if (auto done = capture([&] { verify(path, deep, rep); }); !done) rep.failure = done.failure();
    return rep;
}

}  // namespace tetlod
