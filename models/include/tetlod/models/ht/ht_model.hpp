#pragma once
// The Hierarchy of Tetrahedra (HT) of a scalar volume: the multiresolution model
// of Danovaro, De Floriani, Lee, Samet, "Multiresolution tetrahedral meshes: an
// analysis and a comparison". A (2^k+1)^3 cube is split into 6 tetrahedra around
// its main diagonal and refined by longest-edge bisection; conforming updates are
// diamonds (the 6, 4 or 8 tets sharing a split edge), keyed by the grid point at
// the middle of that edge.
//
// What the model stores: the field, and per diamond the largest exact field
// error of its tetrahedra (per-diamond errors, see docs/ht.md): 4 bytes per grid
// point. Queries judge each tetrahedron by the error of its diamond, which bounds
// the tet's own error, so every bound holds at every grid point.
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "tetlod/models/lod_query.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/zeroed_allocator.hpp"

namespace tetlod {

/// Where the data sits inside the hierarchy's cube [0, L]^3.
struct HtDomain {
    int k = 0;           // L = 2^k
    int32_t L = 1;       // side of the enclosing cube, in grid steps
    /// Extent of the data box B = [0, bx] x [0, by] x [0, bz] (= dims - 1).
    /// With padding, B is the whole cube.
    std::array<int32_t, 3> box_max{0, 0, 0};
    /// Dims of the volume as given by the user (before padding).
    Dims source_dims;
    bool padded = false;

    /// Grid points of B (the field array's dims).
    Dims dims() const { return Dims{box_max[0] + 1, box_max[1] + 1, box_max[2] + 1}; }
    /// Deepest level (unit Kuhn tets); levels run 0..max_level().
    int max_level() const { return 3 * k; }
    bool in_box(int32_t x, int32_t y, int32_t z) const {
        return x >= 0 && y >= 0 && z >= 0 && x <= box_max[0] && y <= box_max[1] &&
               z <= box_max[2];
    }

    /// Domain of a volume with the given dims (dims >= 1 each; a single-sample axis
    /// is not a 3D domain and is refused: every axis needs at least 2 samples).
    static HtDomain for_dims(const Dims& dims, bool pad);
};

struct HtBuildOptions {
    /// Embed the data in the enclosing (2^k+1)^3 cube, extending the values
    /// (each outside point takes the value of the nearest data point); meshes then
    /// cover the padded cube.
    bool pad = false;
    /// Worker threads (0 = TBB default).
    int threads = 0;
};

struct HtExtractStats {
    double max_error = 0.0;     // largest stored error bound among output tets
    uint64_t split_diamonds = 0;
    uint64_t visited_tets = 0;
    double refine_seconds = 0;  // phase 1: computing the split set
    double emit_seconds = 0;    // phase 2: writing the mesh
};

class HtModel {
public:
    /// Builds the model: computes the exact error of every diamond. The volume
    /// is moved in (padded first when options.pad).
    static HtModel build(Volume volume, const HtBuildOptions& options = {});

    /// Reassembles a model from stored parts (container decoders). `errors` has
    /// one entry per grid point of domain.dims(); entries at points that are not
    /// diamond centres are ignored. Throws tetlod::Error on inconsistent sizes.
    /// `field_error`: how far the stored field may be from the original at any
    /// grid point (a lossy container's E; 0: the field is the original). The
    /// errors must already include it (stored bound + E), and it becomes the
    /// bound of the finest tets (field_error_bound).
    static HtModel from_parts(Volume field, const HtDomain& domain, ZeroedVector<float> errors,
                              double field_error = 0);
    /// A model over storage it shares with its maker, without copying it: the
    /// lazy container reader decodes further chunks into that storage between
    /// queries (never during one). Same checks as from_parts; `range` is given.
    static HtModel over_shared_parts(std::shared_ptr<const Volume> field, const HtDomain& domain,
                                     std::shared_ptr<const ZeroedVector<float>> errors,
                                     std::array<double, 2> range, double field_error = 0);

    const HtDomain& domain() const { return domain_; }
    /// The field on B (padded when domain().padded).
    const Volume& field() const { return *field_; }
    /// Per-diamond error, indexed like the field (x fastest). +inf marks diamonds
    /// that must always split because one of their tets crosses the far faces of B;
    /// 0 at the cube corners (not diamonds).
    std::span<const float> diamond_errors() const { return {errors_->data(), errors_->size()}; }

    /// Selective refinement: the coarsest conforming mesh in which every tet
    /// satisfies its bound (unique, see docs/ht.md). Covers exactly B.
    TetMesh extract(const LodQuery& query, HtExtractStats* stats = nullptr) const;
    /// The same mesh handed to `sink` in parts, tet for tet in the same order:
    /// the vertices, then the tets in batches as the walk emits them, so that
    /// memory holds the split set and one batch of tets, never the whole mesh.
    void extract_to(const LodQuery& query, TetMeshSink& sink, HtExtractStats* stats = nullptr) const;

    /// The bound against the original of a tet with no diamond error: a unit
    /// tet, whose grid points are its vertices. 0 unless the field is lossy
    /// (a lossy container's E, rounded up to float), so that every output tet's
    /// `error` holds against the original data, the finest ones included.
    float field_error_bound() const { return field_error_bound_; }

    /// The value range [min, max] of the field (for percent thresholds).
    std::array<double, 2> value_range() const { return range_; }

private:
    HtDomain domain_;
    // Shared, immutable while the model is used: copies of a model share them.
    std::shared_ptr<const Volume> field_;
    std::shared_ptr<const ZeroedVector<float>> errors_;
    std::array<double, 2> range_{0, 0};
    float field_error_bound_ = 0;
};

}  // namespace tetlod
