#pragma once
// `tetlod convert FILE.h5:/dataset out.tlod` over MPI ranks: every rank reads
// its slab of planes by collective hyperslab reads (parallel HDF5), computes the
// errors of its planes and encodes the rows of bricks starting there
// (rank_encode.hpp); every rank writes its sections with MPI-IO at offsets
// rank 0 lays out. Same bytes as `tetlod convert` for any number of ranks.
// What is distributed and what is not: docs/distributed.md.
//
// Collective over `comm`. Failures on any rank end the call on every rank with
// the same RankFailure (lowest failing rank); the output is written into a
// temporary file renamed by rank 0 at the end, so a failure leaves nothing at
// `output`.
#include <mpi.h>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rank_failure.hpp"
#include "slab_planes.hpp"
#include "tetlod/container.hpp"
#include "tetlod/converters/volume_read_options.hpp"

namespace tetlod::mpi {

struct MpiConvertOptions {
    ContainerWriteOptions write;                 // HT only (the MT is built whole)
    VolumeReadOptions read;                      // axis order, spacing, origin overrides
    std::map<std::string, std::string> meta;     // user metadata (convert --meta)
    bool force = false;                          // replace an existing output (-f)
    /// Testing only: this rank reports a read failure after its slab is read
    /// (the environment variable TETLOD_MPI_TEST_FAIL_RANK in tetlod-mpi).
    int fail_rank = -1;
    /// ... in that phase: "read" (after its slab is read), "scan" (after its
    /// first pass), "errors" (after its errors), "encode" (after encoding its
    /// rows of bricks). TETLOD_MPI_TEST_FAIL_PHASE.
    std::string fail_phase = "read";
};

struct MpiConvertResult {
    std::optional<RankFailure> failure;  // the same on every rank
    ContainerWriteSummary summary;       // rank 0
    Volume header;                       // the volume's header (every rank, once opened)
    std::vector<SlabTraffic> traffic;    // rank 0: one per rank
};

/// `input`: FILE.h5:/dataset (or FILE.h5, its only dataset).
MpiConvertResult convert_mpi(MPI_Comm comm, const std::string& input, const std::string& output,
                             const MpiConvertOptions& options);

/// FILE.h5:/dataset -> {FILE.h5, /dataset}: the cut the serial tools make
/// (after the first .h5/.hdf5/.he5 extension followed by ':'), {input, ""} when
/// there is none.
std::pair<std::string, std::string> split_hdf5_location(const std::string& input);

}  // namespace tetlod::mpi
