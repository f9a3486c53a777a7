// Failure agreement across ranks. See rank_failure.hpp.
#include "rank_failure.hpp"

#include <cstdint>
#include <new>
#include <vector>

namespace tetlod::mpi {

std::optional<RankFailure> run_local(const std::function<void()>& phase, int rank) {
    try {
        phase();
        return std::nullopt;
    } catch (const Error& e) {
        return RankFailure{e.code(), e.what(), rank};
    } catch (const std::bad_alloc&) {
        return RankFailure{ErrorCode::TooLarge, "out of memory", rank};
    } catch (const std::exception& e) {
        return RankFailure{ErrorCode::Ok, e.what(), rank, /*internal=*/true};
    }
}

std::optional<RankFailure> agree(MPI_Comm comm, const std::optional<RankFailure>& local) {
    int rank = 0, size = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
    const int mine = local ? rank : size;
    int first = size;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
    if (first == size) return std::nullopt;
    // The first failing rank broadcasts its code and message.
    int64_t head[3] = {0, 0, 0};
    std::string text;
    if (rank == first) {
        head[0] = int64_t(local->code);
        head[1] = int64_t(local->message.size());
        head[2] = local->internal ? 1 : 0;
        text = local->message;
    }
    MPI_Bcast(head, 3, MPI_INT64_T, first, comm);
    text.resize(std::size_t(head[1]));
    if (head[1] > 0) MPI_Bcast(text.data(), int(head[1]), MPI_CHAR, first, comm);
    return RankFailure{ErrorCode(head[0]), std::move(text), first, head[2] != 0};
}

std::optional<RankFailure> run_phase(MPI_Comm comm, const std::function<void()>& phase) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    return agree(comm, run_local(phase, rank));
}

}  // namespace tetlod::mpi
