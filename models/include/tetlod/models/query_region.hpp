#pragma once
// Regions of interest beyond the box and the isovalues: the extension point of
// the LOD query. A region decides, for one closed tetrahedron, whether it meets
// the region; the refiners of every model (HT, MT) ask it through
// query_bound (models/src/query/lod_query_region.hpp), so a region written once
// works for both models, from a volume or a container, in the CLI and Python.
//
// A new kind of region is one file (models/src/query/regions/<name>_region.cpp:
// the QueryRegion subclass and its QueryRegionKind) plus one line in
// models/src/query/query_region_registry.cpp. The command line then offers
// `--<name> TEXT` on extract, decode and isosurface, and Python takes
// `regions={"<name>": "TEXT"}`. A program may also put any QueryRegion of its
// own into LodQuery::regions without registering anything, or register a kind
// at run time (register_query_region_kind) for the table-driven front ends.
//
// Contract of meets(): deterministic (the same answer for the same tet, so that
// both models and every thread count give the same mesh), and conservative only
// in one direction: answering true for a tet that does not meet the region makes
// the mesh finer, never wrong; answering false for one that does breaks the
// query's promise. Called concurrently from several threads: no mutable state.
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>

namespace tetlod {

/// Corners of a tetrahedron in grid index coordinates.
using TetCorners = std::array<std::array<int32_t, 3>, 4>;

class QueryRegion {
public:
    virtual ~QueryRegion() = default;
    /// Does the closed tet meet the region? `values`: the field at the four
    /// corners; `error`: the tet's error bound (|f - linear interpolation| <=
    /// error at every grid point of the tet), for regions defined by the field.
    virtual bool meets(const TetCorners& corners, const std::array<double, 4>& values, double error) const = 0;
    /// Short text for reports, e.g. "sphere 32,32,32 r 10".
    virtual std::string describe() const = 0;
};

/// A kind of region as the front ends (CLI, Python) offer it.
struct QueryRegionKind {
    std::string name;    // lower case, [a-z0-9-]; the flag is --<name>
    std::string syntax;  // what the text looks like, e.g. "cx,cy,cz,r"
    std::string help;    // one line for --help
    /// The region of a text; throws tetlod::Error(InvalidArgument) naming what is wrong.
    std::function<std::shared_ptr<const QueryRegion>(const std::string& text)> parse;
};

/// The registered kinds: the built-in ones first, in registration order.
const std::deque<QueryRegionKind>& query_region_kinds();
/// The kind named `name` (exact, lower case), or nullptr.
const QueryRegionKind* find_query_region_kind(const std::string& name);
/// Adds a kind. InvalidArgument when the name is malformed, taken, or names a
/// flag the query already has (box, isovalue, error, error-out, full).
void register_query_region_kind(QueryRegionKind kind);

}  // namespace tetlod
