#pragma once
// What a LodQuery asks of one tetrahedron, in one place for every model: the
// HT refiner (per diamond tet) and the MT refiner (per front tet) both ask
// `query_bound` for the error bound a tet must honour, so a new kind of region
// is written here (and its validation in lod_query.cpp), not once per model.
#include <algorithm>
#include <array>
#include <cstdint>

#include "tetlod/models/detail/tet_box_intersection.hpp"
#include "tetlod/models/lod_query.hpp"
#include "tetlod/models/query_region.hpp"

namespace tetlod::detail {

/// The bounds a query sets, resolved once: `full` is -1 everywhere; without a
/// region, error_in everywhere.
struct QueryBounds {
    double in = 0, out = 0;  // inside / outside the region
    bool region = false;     // does the bound depend on the tet at all?
    double min() const { return std::min(in, out); }
    double max() const { return std::max(in, out); }
};

inline QueryBounds query_bounds(const LodQuery& q) {
    QueryBounds b;
    b.in = q.full ? -1.0 : q.error_in;
    b.out = q.full ? -1.0 : (q.has_region() ? q.error_out : q.error_in);
    b.region = q.has_region() && !q.full;
    return b;
}

/// Is the tet in the query's region? `corners`: grid index coordinates;
/// `value_of(i)`: the field at corner i (read only when a value test needs it);
/// `err`: the tet's error bound (|f - linear interpolation| <= err on the tet).
/// Every part of the region given must hold (box AND isovalue).
template <class ValueOf>
bool in_query_region(const LodQuery& q, const std::array<std::array<int32_t, 3>, 4>& corners,
                     ValueOf&& value_of, double err) {
    if (q.box) {
        const auto& b = *q.box;
        if (!geometry::tet_meets_box(corners, {b[0], b[1], b[2]}, {b[3], b[4], b[5]})) return false;
    }
    if (!q.isovalues.empty()) {
        double lo = value_of(0), hi = lo;
        for (int i = 1; i < 4; ++i) {
            const double f = value_of(i);
            lo = std::min(lo, f), hi = std::max(hi, f);
        }
        // Every grid point p of the tet has |f(p) - L_T(p)| <= err and L_T lies
        // between the vertex values, so f over the tet lies in [lo-err, hi+err].
        lo -= err, hi += err;
        bool hit = false;
        for (double v : q.isovalues) hit = hit || (lo <= v && v <= hi);
        if (!hit) return false;
    }
    if (!q.regions.empty()) {
        const std::array<double, 4> values{value_of(0), value_of(1), value_of(2), value_of(3)};
        for (const auto& r : q.regions)
            if (!r->meets(corners, values, err)) return false;
    }
    return true;
}

/// The error bound the tet must honour under the query.
template <class ValueOf>
double query_bound(const LodQuery& q, const QueryBounds& b, const std::array<std::array<int32_t, 3>, 4>& corners,
                   ValueOf&& value_of, double err) {
    if (!b.region) return b.in;
    return in_query_region(q, corners, value_of, err) ? b.in : b.out;
}

/// Throws InvalidArgument for a query no model can answer: an inverted box, a
/// non-finite isovalue, a NaN bound, a null region.
void check_query(const LodQuery& q);

}  // namespace tetlod::detail
