#pragma once
// The library's registered query regions made for tests, each paired with an
// independent oracle (tests/support) that decides from the definition whether a
// tet meets it. Test oracles of the refinement ask `oracle_meets_regions` for
// the regions of a query instead of calling the library's own test.
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "support/mesh_checker.hpp"
#include "tetlod/models/lod_query.hpp"
#include "tetlod/models/query_region.hpp"

namespace tetlod::test {

using RegionOracle = std::function<bool(const TetPts&)>;

inline std::map<const QueryRegion*, RegionOracle>& region_oracles() {
    static std::map<const QueryRegion*, RegionOracle> oracles;
    return oracles;
}

/// The library's sphere region (through the registry, as the CLI makes it) of an
/// integer centre and radius, with the exact oracle tet_meets_ball.
inline std::shared_ptr<const QueryRegion> sphere_region(std::array<int64_t, 3> c, int64_t r) {
    const QueryRegionKind* kind = find_query_region_kind("sphere");
    if (!kind) throw std::logic_error("no sphere region registered");
    auto region = kind->parse(std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]) +
                              "," + std::to_string(r));
    region_oracles()[region.get()] = [c, r](const TetPts& t) { return tet_meets_ball(t, c, r); };
    return region;
}

/// Does the tet meet every region of `q` (true without regions), by the oracles?
inline bool oracle_meets_regions(const LodQuery& q, const TetPts& t) {
    for (const auto& r : q.regions) {
        auto it = region_oracles().find(r.get());
        if (it == region_oracles().end()) {
            ADD_FAILURE() << "no oracle for region " << r->describe();
            return false;
        }
        if (!it->second(t)) return false;
    }
    return true;
}

}  // namespace tetlod::test
