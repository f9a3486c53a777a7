// The one list of built-in query regions beyond the box and the isovalues (see
// tetlod/models/query_region.hpp). A new kind adds its entry function
// (regions/<name>_region.cpp) and one line below.
#include <algorithm>

#include "tetlod/core/error.hpp"
#include "tetlod/models/query_region.hpp"

namespace tetlod {

QueryRegionKind sphere_region_kind();

namespace {

std::deque<QueryRegionKind> built_in_kinds() {
    return {
        sphere_region_kind(),
    };
}

// A deque: registering a kind never moves the others.
std::deque<QueryRegionKind>& table() {
    static std::deque<QueryRegionKind> t = built_in_kinds();
    return t;
}

}  // namespace

const std::deque<QueryRegionKind>& query_region_kinds() { return table(); }

const QueryRegionKind* find_query_region_kind(const std::string& name) {
    for (const auto& k : table())
        if (k.name == name) return &k;
    return nullptr;
}

void register_query_region_kind(QueryRegionKind kind) {
    const bool well_formed = !kind.name.empty() && kind.parse &&
                             std::all_of(kind.name.begin(), kind.name.end(), [](char c) {
                                 return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
                             });
    if (!well_formed)
        throw Error(ErrorCode::InvalidArgument,
                    "query region '" + kind.name + "': a name of [a-z0-9-] and a parser are required");
    for (const char* taken : {"box", "isovalue", "error", "error-out", "full"})
        if (kind.name == taken)
            throw Error(ErrorCode::InvalidArgument, "query region '" + kind.name + "': the query already has --" +
                                                        kind.name);
    if (find_query_region_kind(kind.name))
        throw Error(ErrorCode::InvalidArgument, "query region '" + kind.name + "' is already registered");
    table().push_back(std::move(kind));
}

}  // namespace tetlod
