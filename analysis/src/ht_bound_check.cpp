// Brute-force check of an HT's diamond bounds (see ht_bound_check.hpp). The hierarchy
// is walked from spec/ht-model.md §H1 alone: the 6 Kuhn roots of the cube, Maubach's
// ordered bisection with tags, a tet's centre the midpoint of its spine x0-xj.
#include "tetlod/analysis/ht_bound_check.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <tbb/parallel_for.h>

#include "exact_tet_error.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/value_type.hpp"

namespace tetlod {

namespace {

using namespace exact_tet;
using Point = std::array<int64_t, 3>;

struct HierTet {
    std::array<Point, 4> x;
    int tag = 3;  // j: the spine is x0-xj
    int level = 0;
};

/// The two children of spec/ht-model.md §H1's bisect, in its order.
std::array<HierTet, 2> bisect(const HierTet& t) {
    const int j = t.tag;
    Point z;
    for (int a = 0; a < 3; ++a) z[a] = (t.x[0][a] + t.x[size_t(j)][a]) / 2;
    const int jj = j == 1 ? 3 : j - 1;
    HierTet c1 = t, c2 = t;
    c1.x[size_t(j)] = z;
    // child2 = (x1, ..., xj, z, x(j+1), ..., x3)
    int n = 0;
    for (int i = 1; i <= j; ++i) c2.x[size_t(n++)] = t.x[size_t(i)];
    c2.x[size_t(n++)] = z;
    for (int i = j + 1; i <= 3; ++i) c2.x[size_t(n++)] = t.x[size_t(i)];
    c1.tag = c2.tag = jj;
    c1.level = c2.level = t.level + 1;
    return {c1, c2};
}

Point centre(const HierTet& t) {
    Point c;
    for (int a = 0; a < 3; ++a) c[a] = (t.x[0][a] + t.x[size_t(t.tag)][a]) / 2;
    return c;
}

Point sub(const Point& a, const Point& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Point cross(const Point& a, const Point& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
int64_t dot(const Point& a, const Point& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

enum class Place { Inside, Crossing, Outside };

/// Where the tet lies against B = [0, b]: Inside (every corner in B), Outside (its
/// open interior misses B: some axis separates them, touching allowed), else
/// Crossing. Candidate axes of two convex polytopes: the box's face normals, the
/// tet's face normals, and the cross products of their edges; the interior of a
/// full-dimensional tet misses the closed box exactly when one of them separates
/// them weakly. Exact in 64-bit integers (coordinates below 2^13).
Place place(const HierTet& t, const Point& b) {
    bool inside = true;
    for (const Point& p : t.x)
        for (int a = 0; a < 3; ++a) inside = inside && p[a] >= 0 && p[a] <= b[a];
    if (inside) return Place::Inside;
    auto separates = [&](const Point& n) {
        if (n[0] == 0 && n[1] == 0 && n[2] == 0) return false;
        int64_t tmin = dot(n, t.x[0]), tmax = tmin;
        for (int i = 1; i < 4; ++i) {
            const int64_t v = dot(n, t.x[size_t(i)]);
            tmin = std::min(tmin, v), tmax = std::max(tmax, v);
        }
        int64_t bmin = 0, bmax = 0;
        for (int a = 0; a < 3; ++a) (n[a] > 0 ? bmax : bmin) += n[a] * b[a];
        return tmax <= bmin || tmin >= bmax;
    };
    const Point axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (const Point& n : axes)
        if (separates(n)) return Place::Outside;
    std::array<Point, 6> edges;
    int e = 0;
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) edges[size_t(e++)] = sub(t.x[size_t(j)], t.x[size_t(i)]);
    for (int i = 0; i < 4; ++i) {
        const Point& a = t.x[size_t((i + 1) & 3)];
        if (separates(cross(sub(t.x[size_t((i + 2) & 3)], a), sub(t.x[size_t((i + 3) & 3)], a))))
            return Place::Outside;
    }
    for (const Point& edge : edges)
        for (const Point& n : axes)
            if (separates(cross(edge, n))) return Place::Outside;
    return Place::Crossing;
}

template <class V>
struct Walker {
    const V* f;
    Dims dims;
    int max_level;  // 3k: unit tets, never bisected
    Point b;
    std::span<const float> bounds;
    double E;
    HtBoundCheck out;

    void violation(const HierTet& t, const Point& c, bool crossing, double stored, double exact, int64_t at) {
        if (out.violations++ > 0) return;
        HtBoundViolation v;
        v.centre = c;
        v.level = t.level;
        v.tet = t.x;
        v.crossing = crossing;
        v.stored = stored;
        v.exact = exact;
        v.at = at;
        out.first = v;
    }

    bool in_b(const Point& p) const {
        return p[0] >= 0 && p[1] >= 0 && p[2] >= 0 && p[0] <= b[0] && p[1] <= b[1] && p[2] <= b[2];
    }

    /// Checks the tet; false when its subtree holds nothing to check (it lies outside B).
    bool check(const HierTet& t) {
        const Place where = place(t, b);
        if (where == Place::Outside) return false;
        const Point c = centre(t);
        if (!in_b(c)) return true;  // a crossing tet whose diamond has no stored bound
        const double stored = double(bounds[size_t(dims.index(c[0], c[1], c[2]))]);
        if (where == Place::Crossing) {
            ++out.crossing_tets;
            if (!(stored == INFINITY)) violation(t, c, true, stored, INFINITY, dims.index(c[0], c[1], c[2]));
            return true;
        }
        std::array<int64_t, 4> corner;
        for (int i = 0; i < 4; ++i) corner[size_t(i)] = dims.index(t.x[size_t(i)][0], t.x[size_t(i)][1], t.x[size_t(i)][2]);
        const TetGeometry g = geometry(t.x);
        if (g.D == 0) throw Error(ErrorCode::CorruptData, "HT bound check: a flat tet in the hierarchy (internal error)");
        const TetBoundOutcome r = check_tet_bound(f, dims, corner, g, stored, E);
        out.points_visited += r.points;
        out.exact_comparisons += r.exact_comparisons;
        if (!r.finite) {
            ++out.nonfinite_tets;
            return true;
        }
        ++out.tets_checked;
        if (std::isnan(stored) || !r.holds) {
            violation(t, c, false, stored, r.exact, r.at);
        } else if (std::isfinite(stored) && r.exact + E > 0) {
            out.worst_ratio = std::max(out.worst_ratio, stored / (r.exact + E));
        }
        return true;
    }

    /// The subtree of `root` (itself included), depth first, children in order.
    void walk(const HierTet& root) {
        std::vector<HierTet> stack{root};
        while (!stack.empty()) {
            const HierTet t = stack.back();
            stack.pop_back();
            if (t.level >= max_level || !check(t)) continue;
            const auto kids = bisect(t);
            stack.push_back(kids[1]);  // popped after kids[0]'s subtree
            stack.push_back(kids[0]);
        }
    }
};

void merge(HtBoundCheck& into, const HtBoundCheck& part) {
    into.tets_checked += part.tets_checked;
    into.crossing_tets += part.crossing_tets;
    into.nonfinite_tets += part.nonfinite_tets;
    into.points_visited += part.points_visited;
    into.exact_comparisons += part.exact_comparisons;
    into.worst_ratio = std::max(into.worst_ratio, part.worst_ratio);
    if (part.violations != 0 && into.violations == 0) into.first = part.first;
    into.violations += part.violations;
}

}  // namespace

HtBoundCheck check_ht_bounds(const Volume& field, int k, const std::array<int64_t, 3>& box_max,
                             std::span<const float> bounds, double field_error) {
    if (!(field_error >= 0) || !std::isfinite(field_error))
        throw Error(ErrorCode::InvalidArgument, "HT bound check: E must be finite and >= 0");
    if (k < 0 || k > 12) throw Error(ErrorCode::InvalidArgument, "HT bound check: k out of range");
    const int64_t L = int64_t(1) << k;
    for (int a = 0; a < 3; ++a)
        if (box_max[size_t(a)] < 1 || box_max[size_t(a)] > L)
            throw Error(ErrorCode::InvalidArgument, "HT bound check: the data box does not fit the cube");
    const Dims dims{box_max[0] + 1, box_max[1] + 1, box_max[2] + 1};
    if (!(field.dims == dims) || bounds.size() != size_t(dims.count()))
        throw Error(ErrorCode::InvalidArgument, "HT bound check: field or bounds do not cover the data box");
    return dispatch_value_type(field.type, [&](auto tag) {
        using V = decltype(tag);
        // Pieces in depth-first order: each tet above split_level alone, each tet at it
        // with its whole subtree. They run on the TBB threads and merge in that order,
        // so the first violation and every count are those of one sequential walk.
        const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
        const int max_level = 3 * k;
        const int split_level = std::min(max_level, 6);
        std::vector<HierTet> stack;
        for (int r = 5; r >= 0; --r) {
            HierTet t;
            const int p = perms[r][0], q = perms[r][1];
            t.x[0] = {0, 0, 0};
            t.x[1] = {0, 0, 0}, t.x[1][size_t(p)] = L;
            t.x[2] = t.x[1], t.x[2][size_t(q)] = L;
            t.x[3] = {L, L, L};
            stack.push_back(t);
        }
        struct Piece {
            HierTet tet;
            bool subtree;
        };
        std::vector<Piece> pieces;
        while (!stack.empty()) {
            const HierTet t = stack.back();
            stack.pop_back();
            if (t.level >= max_level || place(t, box_max) == Place::Outside) continue;  // nothing to check below
            pieces.push_back({t, t.level == split_level});
            if (t.level == split_level || t.level + 1 >= max_level) continue;
            const auto kids = bisect(t);
            stack.push_back(kids[1]);
            stack.push_back(kids[0]);
        }
        std::vector<HtBoundCheck> parts(pieces.size());
        tbb::parallel_for(size_t(0), pieces.size(), [&](size_t i) {
            Walker<V> w{field.as<V>(), dims, max_level, box_max, bounds, field_error, {}};
            if (pieces[i].subtree) w.walk(pieces[i].tet);
            else w.check(pieces[i].tet);
            parts[i] = w.out;
        });
        HtBoundCheck out;
        for (const HtBoundCheck& part : parts) merge(out, part);
        return out;
    });
}

}  // namespace tetlod
