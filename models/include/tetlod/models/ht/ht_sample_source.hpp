#pragma once
// Selective refinement of an HT whose data is not in memory: the refinement
// asks a sample source for the diamond errors and field values it examines,
// and nothing else. A container reader that decodes chunks on demand is one
// (codecs/ht: extract_ht_lazy); the in-memory HtModel reads its own arrays.
//
// Cost: the refinement keeps its split set and vertex numbering in a map sized
// by the output, never by the grid, so a query costs what it examines.
#include <array>
#include <cstdint>
#include <memory>

#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/lod_query.hpp"

namespace tetlod {

class HtSampleSource {
public:
    using Point = std::array<int32_t, 3>;
    virtual ~HtSampleSource() = default;
    /// Error of the diamond centred at p (p in B, a diamond centre): as
    /// HtModel::diamond_errors() holds it. May throw tetlod::Error (corrupt data).
    virtual float error(const Point& p) = 0;
    /// Field value at p (p in B).
    virtual double value(const Point& p) = 0;
    /// HtModel::field_error_bound of the data: the bound of a unit tet against
    /// the original (a lossy container's E rounded up to float; 0: lossless).
    virtual float field_error_bound() { return 0.0f; }
    /// A source for another thread, reading the same data. Both phases of the
    /// refinement run in parallel and use one per thread or task (this one
    /// only for the root tets); a source is used by one thread at a time.
    virtual std::unique_ptr<HtSampleSource> fork() = 0;
    /// A hint from the refinement: the errors at these points (the children
    /// of a diamond it has queued for splitting) will be read. A source that
    /// decodes its data in pieces may start on them in the background; what
    /// it returns must not depend on whether it did. Default: nothing.
    virtual void prefetch(const Point* points, int count) {
        (void)points;
        (void)count;
    }
};

/// The mesh HtModel::extract would give for a model with this domain and
/// data, with points, tets, level, error and values filled (geometry, field
/// name and value type are left to the caller). Throws what the source throws.
TetMesh refine_ht(const HtDomain& domain, HtSampleSource& source, const LodQuery& query,
                  HtExtractStats* stats = nullptr);
/// Part of refine_ht_to's output, for distributed extraction (tetlod-mpi
/// extract). Every share computes the whole split set and vertex numbering
/// (they decide the mesh), then emits one run of the bisection walk's
/// subtrees: the runs are cut at equal fractions of the total tet count, so
/// the tets of shares 0, 1, .., count - 1 in turn are the whole mesh's tets
/// in its order. The sink's begin() gets every vertex and the whole mesh's
/// tet count; add() only this share's tets (so a file writer's count check
/// holds for count == 1 only).
struct HtEmitShare {
    int index = 0, count = 1;
    /// Fill the vertex values handed to begin() (only the share that writes
    /// the vertices needs them; the others then read no field chunks for them).
    bool vertex_values = true;
};

/// The same mesh handed to `sink` in parts (see HtModel::extract_to); `labels`
/// gives its geometry, field name and value type. `share`: one part of it
/// (HtEmitShare); the default is all of it.
void refine_ht_to(const HtDomain& domain, HtSampleSource& source, const LodQuery& query, const TetMesh& labels,
                  TetMeshSink& sink, HtExtractStats* stats = nullptr, const HtEmitShare& share = {});

}  // namespace tetlod
