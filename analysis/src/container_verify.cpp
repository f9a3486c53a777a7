// Verification of a .tlod container (see container_verify.hpp). Each stage
// records what it established before the next runs, so a caller can report
// exactly how far a damaged file got.
#include "tetlod/analysis/container_verify.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "tetlod/analysis/mt_bound_check.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

namespace {

std::string number_text(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char b[32];
    std::snprintf(b, sizeof b, "%.6g", v);
    return b;
}

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

// Every stored diamond error bound must be at least the exact error recomputed
// from the decoded field.
void verify_ht_bounds(const std::string& path, HtDecoded& d, VerifyReport& rep) {
    HtBuildOptions bo;
    bo.pad = d.layout.domain.padded;
    Volume v;
    if (d.layout.domain.padded) {
        auto r2 = take(tlod::ContainerReader::open(path));
        v = take(decode_volume(r2));
    } else {
        v = d.field;
    }
    const HtModel m = HtModel::build(std::move(v), bo);
    const auto& truth = m.diamond_errors();
    if (truth.size() != d.errors.size())
        throw Error(ErrorCode::CorruptData, path + ": recomputed model has a different size");
    uint64_t bad = 0, first = 0;
    double worst_ratio = 1.0;
    for (std::size_t i = 0; i < truth.size(); ++i) {
        const float t = truth[i], s = d.errors[i];
        // Lossy (spec §5.1): a diamond bound states the error against the
        // original, so it includes E; the recomputed error is the stored field's.
        if (d.layout.max_error > 0 && !(double(s) >= d.layout.max_error) && s != 0) {
            if (bad++ == 0) first = i;
            continue;
        }
        if (!(s >= t) && !std::isnan(t)) {
            if (bad++ == 0) first = i;
        } else if (t > 0 && std::isfinite(s)) {
            worst_ratio = std::max(worst_ratio, double(s) / double(t));
        }
    }
    if (bad) {
        const Dims dd = d.field.dims;
        throw Error(ErrorCode::CorruptData,
                    path + ": " + std::to_string(bad) +
                        " stored error bounds are below the recomputed errors (first at (" +
                        std::to_string(first % dd.x) + "," + std::to_string(first / dd.x % dd.y) + "," +
                        std::to_string(first / (dd.x * dd.y)) + "): stored " +
                        number_text(d.errors[first]) + ", exact " + number_text(truth[first]) + ")");
    }
    rep.ht_bounds_checked = truth.size();
    rep.ht_worst_bound_ratio = worst_ratio;
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
