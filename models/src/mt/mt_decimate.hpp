#pragma once
// Decimation of one brick of the MT build (docs/mt.md §2, "Bricks"). A brick is a box
// of grid points and the tets of the mesh that lie in it; the points on its faces that
// are not faces of the whole volume, and the vertices of tets that cross a face
// (NodeState::pinned), are frozen: they are neither removed nor survivors. Every tet of
// the brick then stays inside the box, every free vertex has all its tets in the
// brick, and two bricks of one pass touch disjoint tets and disjoint nodes, so they can run in parallel and
// their collapses, concatenated in any fixed order, form one valid collapse sequence
// of the whole mesh.
#include <atomic>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "mt_brick_mesh.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod::mt {

/// Inclusive box of grid points, whole-grid coordinates.
struct BrickBox {
    std::array<int64_t, 3> lo{0, 0, 0}, hi{0, 0, 0};
};

/// The brick faces of one pass, per axis: increasing cell coordinates from 0 to the
/// cells of the axis; brick i of an axis spans faces[i]..faces[i + 1].
using PassFaces = std::array<std::vector<int64_t>, 3>;

/// Node state of every grid point of the whole volume. A brick reads it for its box and
/// writes it for its free points only (in place, as it collapses: no copy per brick), so
/// bricks of one pass never write an entry another one reads or writes. Node ids of nodes a brick creates are provisional
/// (kProvisional + collapse index in the brick) until the merge renumbers them.
struct NodeState {
    std::vector<uint32_t> node, label;
    std::vector<float> err;
    /// 1 for a vertex of a tet that no brick of the current pass holds whole (the tet
    /// crosses a face of the pass's bricks and waits for a later pass): such a vertex
    /// is frozen in every brick, like a point on a brick face. Empty: none.
    std::vector<uint8_t> pinned;
};
inline constexpr uint32_t kProvisional = 0x80000000u;

struct BrickResult {
    std::vector<MtUpdate> updates;  // w, s whole-grid; their masks follow each other in `mask_bits`
    std::vector<uint64_t> mask_bits;
    uint64_t mask_bit_count = 0;
    MtHistory history;  // only with record_history; provisional node ids
    BrickMesh mesh;
    /// What the decimation did, for TETLOD_MT_STATS (docs/mt.md §2, "Speed"); no result
    /// depends on it.
    struct Stats {
        uint64_t evaluations = 0;
        uint64_t skipped = 0;         // evaluations skipped: known to find no target
        uint64_t repeated = 0;        // evaluations skipped: known to find the entry's target again
        uint64_t cut_at_link = 0;     // evaluations ended by the link's face errors (no target ranked)
        uint64_t star_tets = 0;       // tets of the stars evaluated
        uint64_t ranked = 0;          // targets ranked by shape
        uint64_t tried = 0;           // targets whose points were located
        uint64_t gathered = 0;        // points gathered (once per evaluation that needs them)
        uint64_t located = 0;         // points located in a target's new tets
        uint64_t commits = 0;
        uint64_t commits_reused = 0;  // commits that reused their evaluation's located points
        uint64_t parallel_walks = 0;  // target walks of points run on several threads (past kSequentialPoints)
        uint64_t compactions = 0;     // squeezes of the dead owned-point blocks
        void add(const Stats& o) {
            evaluations += o.evaluations, skipped += o.skipped, repeated += o.repeated, cut_at_link += o.cut_at_link, star_tets += o.star_tets;
            ranked += o.ranked, tried += o.tried, gathered += o.gathered, located += o.located;
            commits += o.commits, commits_reused += o.commits_reused, parallel_walks += o.parallel_walks;
            compactions += o.compactions;
        }
    } stats;
};

/// Progress inside a brick: (collapses so far, free vertices at the start), every
/// kCollapsesPerReport collapses. The second is an upper bound of the first.
using BrickProgress = std::function<void(uint64_t, uint64_t)>;
inline constexpr uint64_t kCollapsesPerReport = 4096;

/// An estimate of the bytes decimate_brick holds while it runs on `input` (or on the
/// reference mesh of `box` when `input` is empty): its tets, points, per-vertex state
/// and heap. The build admits bricks against a budget with it; it changes no result.
size_t brick_working_bytes(const BrickBox& box, const std::vector<BrickMesh*>& input);

/// Decimates the brick. `input`: the tets of the brick (the previous pass's tets that
/// lie in its box, in a fixed order), emptied once read; empty: start from the
/// reference mesh of the box. Deterministic: the result depends only on the arguments
/// (not on `progress`, which may be empty, nor on `spare_threads`: while it reads
/// true, evaluations of many points walk them on the calling arena's threads, for
/// the same answers; the build sets it once no brick of the pass is left to start).
BrickResult decimate_brick(const Volume& vol, const MtBuildOptions& opt, const BrickBox& box,
                           const std::vector<BrickMesh*>& input, NodeState& nodes,
                           const BrickProgress& progress = {}, const std::atomic<bool>* spare_threads = nullptr);

}  // namespace tetlod::mt
