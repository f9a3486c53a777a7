#pragma once
// The edge-based Multi-Tessellation (MT) of a scalar volume: the second model of
// Danovaro, De Floriani, Lee, Samet, "Multiresolution tetrahedral meshes: an
// analysis and a comparison". Built bottom-up from the 5-tets-per-cell reference
// mesh by half-edge collapses (a grid point w merges into a neighbour s, so every
// vertex stays a grid point with its exact value); read backwards, each collapse
// is a vertex split. Normative: spec/mt-model.md; design: docs/mt.md.
//
// History is recorded in node space (spec/mt-model.md §M4): the survivor of every collapse
// gets a fresh node whose label is larger than the labels of its two children and
// of every vertex of its link at creation. Then a split of node v is legal in any
// extracted mesh exactly when every current neighbour has a smaller label (spec/mt-model.md
// §M6), and the tets it removes are its star, ordered canonically (mt_order) and
// partitioned by a bitmask (spec/mt-model.md §M5). No tet lists are stored.
//
// Errors: a tet's error is max |f(p) - L_T(p)| over the grid points p of the
// closed tet. An update's error is the maximum over the tets of its creation star,
// then made monotone up the forest and rounded up to float. The creator of a tet
// (its vertex of largest label) carries a bound on the tet's error, so every query
// bound holds at every grid point.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "tetlod/models/mt/mt_shape_cap.hpp"
#include "tetlod/models/lod_query.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

struct MtBuildOptions {
    /// Stop decimating once the cheapest collapse would cause an error above this
    /// (field units). +inf: decimate as far as legality allows.
    double max_error = std::numeric_limits<double>::infinity();
    /// Refuse collapses whose new tets have a circumradius/shortest-edge ratio above
    /// this (physical coordinates). 0: no cap (quality is then only a tie-breaker).
    /// The default keeps slivers out for a few % more tets (mt_shape_cap.hpp).
    double max_shape_ratio = kDefaultMtMaxShapeRatio;
    /// Keep the explicit tet history (node-space tets removed/created per update),
    /// for the test oracle only: ~400 bytes per grid point.
    bool record_history = false;
    /// Worker threads (0 = TBB default). The model is the same for any value.
    int threads = 0;
    /// Cells per brick edge in the first pass of the bricked build (docs/mt.md §2,
    /// "Bricks"); each further pass doubles it. 0: one brick, the whole volume. The
    /// model depends on it (not on `threads`).
    int brick_cells = 32;
    /// Error cap of the bricked build's last-but-one pass, as a fraction of the value
    /// range; each earlier pass stops at 1/8 of the next one's cap and the last pass
    /// has none, so collapses happen roughly in error order across bricks (docs/mt.md
    /// §2, "Error caps"). +inf: every brick decimates to the end, which is faster but
    /// leaves each pass's brick borders fine in every coarser LOD. The model depends on it.
    double pass_error_cap = 0.03;
    /// Called as (done, total) while building: first (0, total), then as each brick
    /// completes, last with done == total. Units: grid points as they become free to
    /// collapse, weighted by 3^pass (a collapse costs about three times more per pass;
    /// docs/mt.md §2), so done / total follows the time. Called from TBB worker
    /// threads, one call at a time (serialized), with done never decreasing; keep it
    /// cheap. Empty: no reports. The model does not depend on it.
    std::function<void(uint64_t done, uint64_t total)> progress;
};

/// One vertex split (the inverse of collapse w -> s), in node space, as builders
/// and decoders hand it to the model. Its mask (one bit per tet of the star) is not
/// here: masks are concatenated in the order of the updates, so the offset follows
/// from the stars before it (MtModel::mask_offset).
struct MtUpdate {
    uint32_t w = 0;         // grid index of the point the split inserts
    uint32_t s = 0;         // grid index of the survivor (the split node sits here)
    uint32_t label = 0;     // node label, >= 1 (leaves are 0)
    float error = 0.0f;     // conservative error bound of the node's creation star
    uint32_t star = 0;      // tets around the node at creation (= bits of its mask)
};

/// A vertex split as the model keeps it, 16 bytes: the survivor s of MtUpdate is
/// implied by the group of updates it is stored in (MtModel::updates_at,
/// MtModel::survivor), so it is not stored (4 bytes an update, about 4 bytes a
/// grid point).
struct MtSplit {
    uint32_t w = 0;         // grid index of the point the split inserts
    uint32_t label = 0;     // node label, >= 1 (leaves are 0)
    float error = 0.0f;     // conservative error bound of the node's creation star
    uint32_t star = 0;      // tets around the node at creation (= bits of its mask)
};

/// Explicit node-space history (tests only). Node ids: grid index for leaves,
/// n + k for the survivor node of collapse k.
struct MtHistory {
    using Tet = std::array<uint32_t, 4>;  // node ids, as oriented in the mesh
    std::vector<std::vector<Tet>> before;  // per collapse: star(w) U star(s) (the split creates these)
    std::vector<std::vector<Tet>> after;   // per collapse: new star(s) (the split removes these)
    std::vector<Tet> base;                 // final mesh in node ids
    std::vector<uint32_t> update_of_node;  // node n + k (collapse k) -> its index in MtModel::updates()
};

/// A tet of a mesh that a refinement passes through (MtModel::extract_visiting).
struct MtVisitedTet {
    static constexpr uint32_t kNone = 0xFFFFFFFFu;
    std::array<uint32_t, 4> tet{};  // grid indices, positively oriented
    uint32_t creator = kNone;       // grid index of its creator (spec/mt-model.md §M4); kNone: a reference tet
    uint32_t update = kNone;        // the creator's current update, updates()[update]; kNone for a reference tet
};

struct MtExtractStats {
    double max_error = 0.0;      // largest bound among output tets
    uint64_t splits = 0;         // vertex splits performed
    uint64_t forced_splits = 0;  // of which forced by a blocked split
    uint64_t visited_tets = 0;
    uint64_t tets_removed = 0, tets_inserted = 0;  // by the splits
};

class MtModel {
public:
    /// Builds the model from the volume (moved in). Every axis needs >= 2 samples.
    /// Throws tetlod::Error(InvalidArgument/TooLarge) on unusable dims.
    static MtModel build(Volume volume, const MtBuildOptions& options = {});

    /// Reassembles a model from stored parts (decoders). `base_tets` hold grid indices;
    /// `updates` in any order whose labels increase along every survivor's list;
    /// `mask_bits` their masks concatenated in that order.
    /// Checks indices, counts, labels and masks structurally and throws
    /// tetlod::Error(CorruptData) when they are inconsistent; deeper inconsistencies
    /// are caught during extraction (which then throws CorruptData, never crashes).
    static MtModel from_parts(Volume field, std::vector<std::array<uint32_t, 4>> base_tets,
                              std::vector<MtUpdate> updates, std::vector<uint64_t> mask_bits);

    const Volume& field() const { return field_; }
    const Dims& dims() const { return field_.dims; }
    /// The coarsest mesh, grid indices, positively oriented.
    const std::vector<std::array<uint32_t, 4>>& base_tets() const { return base_; }
    /// Updates grouped by survivor (ascending grid index), each group sorted by label:
    /// the same order after build and after decoding (updates_at gives a group,
    /// survivor the group of one update).
    const std::vector<MtSplit>& updates() const { return splits_; }
    /// The survivor (grid index) of updates()[k]: a binary search over the groups.
    uint32_t survivor(size_t k) const;
    const std::vector<uint64_t>& mask_bits() const { return mask_bits_; }
    /// First bit of the mask of updates()[k] in mask_bits(): a sampled prefix sum of the
    /// stars (one 64-bit start per 64 updates, then at most 63 stars added).
    uint64_t mask_offset(size_t k) const {
        uint64_t at = mask_start_[k >> 6];
        for (size_t j = k & ~size_t(63); j < k; ++j) at += splits_[j].star;
        return at;
    }
    /// Bit `b` of mask_bits(): bit i of update k's mask is mask_bit(mask_offset(k) + i).
    bool mask_bit(uint64_t b) const { return (mask_bits_[b >> 6] >> (b & 63)) & 1u; }
    uint32_t max_label() const { return max_label_; }
    /// Only when built with record_history.
    const MtHistory* history() const { return history_.empty() ? nullptr : &history_.front(); }

    /// Selective refinement: the coarsest mesh of the MT (the minimal closed set of
    /// splits) in which every tet meets its bound. Conforming, covers the data box.
    /// TetMesh::level = max_label() - label of the tet's creator, clamped to 255
    /// (0 = created by the coarsest split); TetMesh::error = the creator's bound
    /// (0 for reference tets). Throws tetlod::Error(InvalidArgument) on a bad query,
    /// CorruptData when a decoded model turns out inconsistent.
    TetMesh extract(const LodQuery& query, MtExtractStats* stats = nullptr) const;

    /// extract, reporting every tet of every mesh the refinement passes through,
    /// each once: `visit` gets the base mesh's tets, then, after each split, the
    /// d + |E| tets it created (spec/mt-model.md §M5), in split order. A tet's
    /// creator never changes while it exists (a vertex's label changes only when
    /// it splits, which removes its star), so this is every (tet, creator) pair
    /// reachable on the way; with `query.full`, every tet of a full refinement.
    /// For checkers (tetlod verify --deep); extract itself does no reporting (a
    /// separate instantiation of the refinement, so its speed is unchanged).
    TetMesh extract_visiting(const LodQuery& query,
                             const std::function<void(std::span<const MtVisitedTet>)>& visit,
                             MtExtractStats* stats = nullptr) const;

    std::array<double, 2> value_range() const { return range_; }

    /// The bound against the original of a reference tet (created by no update,
    /// its grid points its vertices): 0 unless the field is a lossy container's,
    /// within E of the original (E rounded up to float). Update errors read from
    /// such a container already include E (spec §5.1).
    float field_error_bound() const { return field_error_bound_; }
    /// Sets it (container readers: the E of a lossy file). Throws
    /// InvalidArgument unless e is finite and >= 0.
    void set_field_error_bound(double e);

    /// Bytes the model holds in memory: the capacities of all its arrays (field,
    /// base mesh, updates, masks, per-point update lists, history) and the object.
    std::size_t memory_bytes() const;

    /// The updates whose survivor is grid point p, sorted by label: updates()[k] for k in
    /// [first_update_at(p), first_update_at(p + 1)).
    std::span<const MtSplit> updates_at(uint32_t p) const {
        return {splits_.data() + csr_start_[p], splits_.data() + csr_start_[p + 1]};
    }
    uint32_t first_update_at(uint32_t p) const { return csr_start_[p]; }

private:
    void finalize();  // sorts updates and masks by (survivor, label), CSR, max label, range; validates

    Volume field_;
    std::vector<std::array<uint32_t, 4>> base_;
    std::vector<MtUpdate> updates_;  // build and from_parts stage here; finalize moves them to splits_
    std::vector<MtSplit> splits_;
    float field_error_bound_ = 0;
    std::vector<uint64_t> mask_bits_;
    std::vector<uint64_t> mask_start_;  // mask offset of updates_[64 j]
    std::vector<uint32_t> csr_start_;   // updates_ of survivor p: [csr_start_[p], csr_start_[p + 1])
    uint32_t max_label_ = 0;
    std::array<double, 2> range_{0, 0};
    std::vector<MtHistory> history_;  // 0 or 1 element

    template <class Observer>
    friend struct MtRefiner;
};

}  // namespace tetlod
