// Brute-force check of an MT's stored update errors (see mt_bound_check.hpp). The
// exact per-tet test is exact_tet_error.hpp's (geometry, exactness); written from
// spec/mt-model.md §M1 and §M4 alone, sharing no code with models/ (the builder's
// error evaluation).
#include "tetlod/analysis/mt_bound_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <type_traits>
#include <vector>

#include <tbb/task_group.h>

#include "exact_tet_error.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

using namespace exact_tet;

// ---- the check ------------------------------------------------------------------

template <class V>
struct Checker {
    const MtModel& mt;
    const V* f;
    Dims dims;
    double E;
    MtBoundCheck out;
    uint32_t X = uint32_t(dims.x), Y = uint32_t(dims.y);

    void violation(const MtVisitedTet& v, double stored, double exact, int64_t at) {
        if (out.violations++ > 0) return;
        MtBoundViolation b;
        b.tet = v.tet;
        b.creator = v.creator;
        if (v.update != MtVisitedTet::kNone) {
            const MtSplit& u = mt.updates()[v.update];
            b.inserts = u.w;
            b.label = u.label;
        }
        b.stored = stored;
        b.exact = exact;
        b.at = uint32_t(at);
        out.first = b;
    }

    void check(const MtVisitedTet& v) {
        std::array<std::array<int64_t, 3>, 4> P;
        for (int i = 0; i < 4; ++i) {  // 32-bit divisions: indices are below 2^31
            const uint32_t g = v.tet[i], row = g / X;
            P[i] = {int64_t(g - row * X), int64_t(row % Y), int64_t(row / Y)};
        }
        const TetGeometry t = geometry(P);
        if (t.D == 0) throw Error(ErrorCode::CorruptData, "MT bound check: a flat tet in the refinement");
        // A reference tet bounds nothing but must be exact (spec/mt-model.md §M2).
        const bool ref = v.creator == MtVisitedTet::kNone;
        const double stored = ref ? 0.0 : double(mt.updates()[v.update].error);
        const double e = ref ? 0.0 : E;
        const std::array<int64_t, 4> corner{v.tet[0], v.tet[1], v.tet[2], v.tet[3]};
        const TetBoundOutcome r = check_tet_bound(f, dims, corner, t, stored, e);
        out.points_visited += r.points;
        out.exact_comparisons += r.exact_comparisons;
        if (!r.finite) {
            ++out.nonfinite_tets;
            return;
        }
        const bool ok = r.holds;
        const double exact = r.exact;
        const int64_t at = r.at;
        ++out.tets_checked;
        if (!ok) {
            violation(v, stored, exact, at);
        } else if (!ref && std::isfinite(stored) && exact + e > 0) {
            out.worst_ratio = std::max(out.worst_ratio, stored / (exact + e));
        }
    }
};

}  // namespace

MtBoundCheck check_mt_bounds(const MtModel& mt, double field_error) {
    if (!(field_error >= 0) || !std::isfinite(field_error))
        throw Error(ErrorCode::InvalidArgument, "MT bound check: E must be finite and >= 0");
    return dispatch_value_type(mt.field().type, [&](auto tag) {
        using V = decltype(tag);
        Checker<V> c{mt, mt.field().as<V>(), mt.dims(), field_error, {}};
        // The refinement is sequential; the check of one buffer of visited tets runs
        // on another thread while the refinement fills the next. One check runs at a
        // time, in the order the tets came, so the result (the first violation
        // included) does not depend on the threads.
        constexpr std::size_t kBuffer = std::size_t(1) << 14;
        std::vector<MtVisitedTet> filling, checking;
        filling.reserve(kBuffer + 1024);
        checking.reserve(kBuffer + 1024);
        tbb::task_group background;
        auto check_all = [&c](const std::vector<MtVisitedTet>& tets) {
            for (const MtVisitedTet& v : tets) c.check(v);
        };
        LodQuery full;
        full.full = true;
        TetMesh m;
        try {
            m = mt.extract_visiting(full, [&](std::span<const MtVisitedTet> tets) {
                filling.insert(filling.end(), tets.begin(), tets.end());
                if (filling.size() < kBuffer) return;
                background.wait();  // rethrows what the previous check threw
                std::swap(filling, checking);
                filling.clear();
                background.run([&] { check_all(checking); });
            });
        } catch (...) {
            background.wait();  // never leave the task running on our buffers
            throw;
        }
        background.wait();
        check_all(filling);
        c.out.full_mesh_tets = m.tet_count();
        return c.out;
    });
}

}  // namespace tetlod
