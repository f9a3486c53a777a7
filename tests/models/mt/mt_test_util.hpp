#pragma once
// Shared helpers of the MT tests: query bounds from the definitions (not from the
// codec), query printing, and cached model builds.
#include <algorithm>
#include <array>
#include <map>
#include <memory>
#include <sstream>
#include <string>

#include "../region_oracles.hpp"
#include "support/mesh_checker.hpp"
#include "support/volume_generators.hpp"
#include "tetlod/models/lod_query.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod::test {

inline std::string dims_str(const Dims& d) {
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z);
}

inline std::string query_str(const LodQuery& q) {
    std::ostringstream o;
    if (q.full) return "full";
    o << "eps_in=" << q.error_in;
    if (q.has_region()) o << " eps_out=" << q.error_out;
    if (q.box) {
        auto& b = *q.box;
        o << " box=[" << b[0] << "," << b[1] << "," << b[2] << ".." << b[3] << "," << b[4] << "," << b[5] << "]";
    }
    for (double v : q.isovalues) o << " iso=" << v;
    for (const auto& r : q.regions) o << " " << r->describe();
    return o.str();
}

/// The bound a query puts on tet T from the definitions: in the region eps_in, out of
/// it eps_out. Isovalue regions: the model may use a conservative (wider) value range,
/// so a tet whose exact range misses every isovalue may be judged by either bound.
inline std::function<double(const TetPts&)> mt_query_bound(const LodQuery& q, const Volume& field) {
    auto clamp0 = [](double e) { return e < 0 ? 0.0 : e; };
    if (q.full) return uniform_bound(0.0);
    if (!q.has_region()) return uniform_bound(clamp0(q.error_in));
    return [q, &field, clamp0](const TetPts& t) {
        bool in = true;
        if (q.box) {
            auto& b = *q.box;
            in = tet_meets_box(t, {int32_t(b[0]), int32_t(b[1]), int32_t(b[2])},
                               {int32_t(b[3]), int32_t(b[4]), int32_t(b[5])});
        }
        in = in && oracle_meets_regions(q, t);
        bool iso_exact = true;
        if (in && !q.isovalues.empty()) {
            TetStats s = exact_tet_stats(field, t);
            iso_exact = false;
            for (double v : q.isovalues) iso_exact = iso_exact || (s.fmin <= v && v <= s.fmax);
        }
        double e;
        if (in && iso_exact) e = q.error_in;
        else if (in) e = std::max(q.error_in, q.error_out);
        else e = q.error_out;
        return clamp0(e);
    };
}

inline CheckOptions mt_check_options(const LodQuery& q, const Volume& field) {
    CheckOptions o;
    o.allowed = mt_query_bound(q, field);
    o.tolerance = float_tolerance(field);
    return o;
}

/// Index-space volume of the box, times 6 (for the volume-sum expectation).
inline int64_t cells(const Dims& d) { return (d.x - 1) * (d.y - 1) * (d.z - 1); }

}  // namespace tetlod::test
