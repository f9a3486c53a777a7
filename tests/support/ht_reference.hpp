#pragma once
// A reference Hierarchy of Tetrahedra built by brute force from Maubach's ordered
// bisection (docs/ht.md, "The hierarchy"), independent of models/:
//  * HtTet / ht_roots / ht_children: the tree itself, lazily;
//  * walk_mesh: locates every tet of an extracted mesh in the tree (every output tet
//    must be a node), and lists the split nodes seen on the way;
//  * find_mergeable_diamonds: the minimality check (no split diamond whose children
//    are all output leaves may be merged without violating the bound);
//  * HtHierarchy + oracle_extract: the whole tree for small k, exact per-tet errors,
//    per-diamond errors and the coarsest conforming mesh by the definition, for
//    exact comparison with the model's output;
//  * shape_ratio: circumradius / shortest edge.
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

#include "support/mesh_checker.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::test {

struct HtTet {
    TetPts x;      // Maubach's ordered tuple: x0 - x[tag] is the spine (longest edge)
    int tag = 3;   // 3, 2, 1
    int level = 0;
};

/// The 6 Kuhn paths of [0, 2^k]^3, tag 3, level 0.
std::array<HtTet, 6> ht_roots(int k);
/// Maubach bisection: z = (x0 + x_tag)/2, children (x0..x_{j-1}, z, x_{j+1}..x3) and
/// (x1..x_j, z, x_{j+1}..x3), tag j-1 (1 -> 3).
std::array<HtTet, 2> ht_children(const HtTet& t);
/// Midpoint of the spine (valid while the spine has even coordinates: level < 3k).
Pt ht_spine_mid(const HtTet& t);

/// Sorted corner coordinates: identifies a tet regardless of vertex order.
using TetKey = std::array<int32_t, 12>;
TetKey tet_key(const TetPts& t);
struct TetKeyHash {
    std::size_t operator()(const TetKey& k) const;
};

enum class BoxStatus { Inside, Outside, Crossing };
/// Exact: Inside if all corners lie in B = [0,bmax]; Outside if its interior misses B;
/// else Crossing. Decided by descending to the unit Kuhn tets, each wholly in or out.
BoxStatus classify(const HtTet& t, const Pt& bmax, int k);

/// Number of tets of the diamond centred at c inside [0, 2^k]^3 (from the diamond
/// classes of spec/tlod-format.md §2: 6 / 4 / 8 interior, fewer on the cube's boundary).
int diamond_size_in_cube(const Pt& c, int k);

/// circumradius / shortest edge.
double shape_ratio(const TetPts& t);

struct MeshWalk {
    int k = 0;
    Pt bmax{};
    std::vector<HtTet> node_of_tet;   // per mesh tet: its hierarchy node (level -1: none)
    std::vector<HtTet> split;          // internal nodes whose bounding box meets B's interior
    std::unordered_map<TetKey, uint32_t, TetKeyHash> leaf;  // key -> mesh tet
    std::vector<std::string> errors;   // readable failures
};
/// Locates every mesh tet in the hierarchy of [0, 2^k]^3 with data box [0, bmax].
/// Errors: mesh tets that are no HT node, duplicated tets, level mismatches (when
/// mesh.level is filled), unit tets of B that no output tet contains.
MeshWalk walk_mesh(const TetMesh& mesh, int k, const Pt& bmax);

/// eps(T): the bound the query gives tet T (eps_in / eps_out by region).
using TetBound = std::function<double(const TetPts&)>;
/// Model-side error of a diamond centre (e.g. HtModel::diamond_errors()); empty: exact.
using DiamondErrorFn = std::function<double(const Pt&)>;

/// Minimality: for every split diamond all of whose tets are inside B and whose
/// children tets are all output leaves, merging it must break the bound for at least
/// one of its tets (per-diamond errors: the diamond's error = max exact error of its
/// tets; model_error, when given, is used instead and must be >= the exact one).
/// Returns readable failures; `checked` receives the number of candidates.
std::vector<std::string> find_mergeable_diamonds(const Volume& field, const MeshWalk& walk,
                                                 const TetBound& eps, const DiamondErrorFn& model_error,
                                                 int64_t* checked = nullptr);

/// The whole hierarchy of [0, 2^k]^3, level by level (tet i has children 2i+6, 2i+7).
/// Memory ~60 B x 6 x 2^(3k+1): use for k <= 5.
struct HtHierarchy {
    explicit HtHierarchy(int k);
    int k;
    int32_t L;
    std::vector<HtTet> tets;
    static std::size_t level_begin(int l) { return 6 * ((std::size_t{1} << l) - 1); }
};

struct OracleResult {
    std::vector<TetKey> mesh;                 // sorted keys of the coarsest mesh
    std::vector<double> diamond_error;        // per cube grid point (L+1)^3: max exact error over inside tets
    std::vector<uint8_t> diamond_forced;      // 1 where a tet of the diamond crosses B
    std::vector<uint8_t> diamond_has_inside;  // 1 where some tet of the diamond is inside B
    std::vector<uint8_t> split;               // split diamonds
};
/// Brute-force selective refinement on a whole hierarchy: box status of every tet
/// (bottom-up from the unit tets), exact errors of every tet inside B, diamonds
/// grouped by spine midpoint, their parents; prepared once per field.
class HtOracle {
public:
    HtOracle(const HtHierarchy& h, const Volume& field);
    /// Coarsest conforming mesh of the definition (spec/ht-model.md §H2-§H3) with
    /// per-diamond errors: exact ones, or model_error(c) for centres in B when given.
    OracleResult extract(const TetBound& eps, const DiamondErrorFn& model_error = {}) const;

private:
    const HtHierarchy& h_;
    std::vector<uint8_t> status_;  // 0 inside, 1 outside, 2 crossing
    std::vector<int64_t> centre_;
    std::vector<std::vector<int32_t>> dtets_, dparents_;
    std::vector<double> derr_;
    std::vector<uint8_t> forced_, has_inside_;
};

/// One-shot HtOracle(h, field).extract(eps, model_error).
OracleResult oracle_extract(const HtHierarchy& h, const Volume& field, const TetBound& eps,
                            const DiamondErrorFn& model_error = {});

/// Float value >= x, the closest one (how a sound model stores an exact error).
float round_up_to_float(double x);

}  // namespace tetlod::test
