#pragma once
// `tetlod extract IN.tlod OUT.vtu --error E [--box .. --error-out E2]` over MPI
// ranks: the same mesh file, byte for byte. Every rank opens the container and
// computes the HT's split set (the refinement decision, which alone fixes the
// mesh and its vertex numbering, reading only the chunks the query examines);
// the bisection walk's output is then cut into as many runs of equal tet
// counts as ranks, each rank emits its run (reading the errors of its tets),
// and rank 0, which writes the vertices and its own run through the serial
// streaming writer, appends the others' runs in rank order. Why this equals
// serial, and what it costs: docs/distributed.md.
//
// Collective over `comm`. A failure on any rank ends the call on every rank
// with the same RankFailure; the output is written atomically by rank 0 (a
// temporary file renamed at the end), so a failure leaves none.
#include <mpi.h>

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rank_failure.hpp"
#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/models/lod_query.hpp"

namespace tetlod::mpi {

struct MpiExtractOptions {
    bool force = false;       // replace an existing output (-f)
    std::string format;       // mesh format name; empty: from the output's extension
    MeshWriteOptions write;   // .vtu compression
    std::size_t cache_bytes = std::size_t{1024} << 20;  // decoded-chunk cache per rank
    /// The query's region (box); its thresholds come from `resolve`, given the
    /// container's value range (percent bounds), as `tetlod extract` resolves them.
    LodQuery query;
    std::function<void(LodQuery&, const std::array<double, 2>& range)> resolve;
    /// Tets travel to rank 0 in messages of at most this many (x 21 bytes).
    std::size_t message_tets = std::size_t{1} << 22;
    /// Testing only: this rank fails after emitting its run (TETLOD_MPI_TEST_FAIL_RANK
    /// in tetlod-mpi, with TETLOD_MPI_TEST_FAIL_PHASE=extract).
    int fail_rank = -1;
};

/// What one rank did, for -v and docs/distributed.md.
struct ExtractTraffic {
    uint64_t tets = 0;          // of its run
    uint64_t chunks_decoded = 0;
    uint64_t bytes_sent = 0;      // its run to rank 0 (ranks > 0)
    uint64_t bytes_received = 0;  // the other ranks' runs (rank 0)
    uint64_t messages = 0;        // point-to-point messages sent and received (collectives not counted)
    double refine_seconds = 0;  // split set (the same work on every rank)
    double emit_seconds = 0;    // its run (rank 0: with writing the vertices and its run)
    double cpu_seconds = 0;     // user CPU time of the process, at the end
    double peak_rss_mb = 0;     // maximum resident set size of the process
};

struct MpiExtractResult {
    std::optional<RankFailure> failure;  // the same on every rank
    Dims dims{};
    ValueType type = ValueType::U8;
    uint64_t tets = 0, vertices = 0;
    double max_error = 0;               // largest error of an output tet (all ranks)
    std::array<double, 2> range{};
    std::vector<ExtractTraffic> traffic;  // rank 0: one per rank
};

/// `input`: a .tlod container holding the HT. `output`: a mesh file whose
/// format the extension (or options.format) names.
MpiExtractResult extract_mpi(MPI_Comm comm, const std::string& input, const std::string& output,
                             const MpiExtractOptions& options);

}  // namespace tetlod::mpi
