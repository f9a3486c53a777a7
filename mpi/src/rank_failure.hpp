#pragma once
// Agreeing on failure across MPI ranks. A run is split into phases that end at
// points every rank reaches (after a collective read, after the write); at each
// one the ranks exchange whether they failed, and every rank leaves with the
// same verdict: the error of the lowest failing rank, which rank 0 prints and
// every rank turns into the same exit code. So a rank that cannot read ends all
// of them, with the message naming the file and the problem.
#include <mpi.h>

#include <functional>
#include <optional>
#include <string>

#include "tetlod/core/error.hpp"

namespace tetlod::mpi {

struct RankFailure {
    ErrorCode code = ErrorCode::Ok;
    std::string message;
    int rank = 0;           // the rank it happened on
    bool internal = false;  // not a tetlod::Error (a bug): exit 1, as `tetlod`
};

/// Runs `phase` and catches what it throws (tetlod::Error keeps its code; out
/// of memory is TooLarge; anything else is reported as an internal error).
std::optional<RankFailure> run_local(const std::function<void()>& phase, int rank);

/// Collective over `comm`: the failure of the lowest rank that passed one, the
/// same on every rank; nullopt when no rank failed.
std::optional<RankFailure> agree(MPI_Comm comm, const std::optional<RankFailure>& local);

/// run_local then agree: the usual end of a phase.
std::optional<RankFailure> run_phase(MPI_Comm comm, const std::function<void()>& phase);

}  // namespace tetlod::mpi
