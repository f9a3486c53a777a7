#pragma once
// `tetlod decode IN.tlod OUT.h5:/dataset` over MPI ranks: every rank decodes
// its slab of planes from the container (rows of the finest bricks,
// row_slabs.hpp, through the library's plane decoder, so a rank holds a
// batch of its planes, one row of bricks and the coarser chunks they need,
// never the volume) and writes it into the dataset with collective hyperslab
// writes (parallel HDF5). The dataset is the one `tetlod decode` writes: same
// type, dims, values and attributes (the same library code creates it).
// Design and measurements: docs/distributed.md.
//
// Collective over `comm`. Failures on any rank end the call on every rank
// with the same RankFailure (lowest failing rank). The ranks write into a
// temporary file rank 0 prepares beside the output (a copy of an existing
// HDF5 file, so its other datasets are kept) and renames at the end, so a
// failure leaves the output as it was and no temporary file.
#include <mpi.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rank_failure.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::mpi {

struct MpiDecodeOptions {
    bool force = false;  // replace an existing dataset (-f), as `tetlod -f decode`
    /// Planes are decoded and written in batches of at most this many bytes
    /// per rank (at least one plane), as the serial writer's 16 MiB: a rank's
    /// buffer is bounded whatever its slab, and each collective write stays far
    /// below MPI-IO's 2 GiB per call.
    std::size_t batch_bytes = std::size_t{16} << 20;
    /// Testing only: this rank fails while decoding its first batch
    /// (TETLOD_MPI_TEST_FAIL_RANK in tetlod-mpi, with TETLOD_MPI_TEST_FAIL_PHASE=decode).
    int fail_rank = -1;
};

/// What one rank did, for -v and docs/distributed.md.
struct DecodeTraffic {
    int64_t z0 = 0, planes = 0;   // its slab
    uint64_t bytes_written = 0;   // samples, to the dataset
    double decode_seconds = 0;    // decoding its planes from the container
    double write_seconds = 0;     // in the collective writes (waiting for the others included)
    double cpu_seconds = 0;       // user CPU time of the process, at the end
    double peak_rss_mb = 0;       // maximum resident set size of the process
};

struct MpiDecodeResult {
    std::optional<RankFailure> failure;  // the same on every rank
    Volume header;                       // the decoded volume's header (every rank, once opened)
    std::vector<std::string> lost_keys;  // metadata keys HDF5 cannot hold (written without, as serial)
    std::vector<DecodeTraffic> traffic;  // rank 0: one per rank
};

/// `input`: a .tlod container holding the HT (an MT-only container is
/// refused: its MT is decoded whole). `output`: FILE.h5:/dataset, or FILE.h5
/// for /volume (the serial default).
MpiDecodeResult decode_mpi(MPI_Comm comm, const std::string& input, const std::string& output,
                           const MpiDecodeOptions& options);

}  // namespace tetlod::mpi
