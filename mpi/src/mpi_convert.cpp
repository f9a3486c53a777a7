// The distributed conversion's phases. See mpi_convert.hpp.
#include "mpi_convert.hpp"

#include <algorithm>
#include <cctype>
#include <memory>

#include "tetlod/core/output_policy.hpp"

namespace tetlod::mpi {

std::pair<std::string, std::string> split_hdf5_location(const std::string& input) {
    std::string lower = input;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    for (const char* ext : {".h5:", ".hdf5:", ".he5:"}) {
        const auto p = lower.find(ext);
        if (p == std::string::npos) continue;
        const std::size_t cut = p + std::char_traits<char>::length(ext) - 1;
        return {input.substr(0, cut), input.substr(cut + 1)};
    }
    return {input, ""};
}

MpiConvertResult convert_mpi(MPI_Comm comm, const std::string& input, const std::string& output,
                             const MpiConvertOptions& o) {
    int rank = 0, size = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
    MpiConvertResult result;
    // Named copies, not a structured binding: clang 14 (the sanitized CI
    // build) cannot capture bindings in the lambdas below.
    const auto location = split_hdf5_location(input);
    const std::string& file = location.first;
    const std::string& dataset = location.second;

    // Rank 0 owns the output: the policy refuses an existing file (without
    // force) or the input itself before anything is read.
    OutputPolicy policy;
    policy.force = o.force;
    policy.force_hint = "use -f/--force to overwrite it";
    std::optional<ScopedOutputPolicy> scope;
    if (rank == 0) scope.emplace(policy);

    // A: local checks, no collective call yet, so a rank that cannot see the
    // file fails alone and the others are not left inside MPI-IO.
    uint64_t file_size = 0;
    result.failure = run_phase(comm, [&] {
        if (o.write.mt) throw Error(ErrorCode::InvalidArgument, "tetlod-mpi converts the HT only (--model ht)");
        if (rank == 0) {
            policy.add_input(file, dataset);
            policy.check_output(output);
        }
        file_size = check_hdf5_mpi_input(file);
    });
    if (result.failure) return result;

    // B: every rank opens the dataset (collective); a missing dataset or a bad
    // type fails the same way on every rank.
    std::unique_ptr<Hdf5MpiDataset> source;
    result.failure = run_phase(comm, [&] { source = open_hdf5_mpi(file, dataset, o.read, file_size, comm); });
    if (result.failure) return result;
    result.header = source->header();
    for (const auto& [k, v] : o.meta) result.header.metadata[k] = v;

    // C: each rank reads its slab (collective hyperslab reads), then every
    // rank closes the file at this same point (closing is collective too).
    const SlabPartition partition{result.header.dims.z, size};
    SlabTraffic traffic;
    LocalSlab slab;
    auto failure = run_local(
        [&] {
            slab = read_local_slab(*source, partition, rank, traffic);
            if (rank == o.fail_rank)
                throw Error(ErrorCode::IoError, "'" + file + ":" + dataset + "': could not read planes " + std::to_string(slab.z0) + ".." +
                                                    std::to_string(slab.z0 + slab.planes - 1) +
                                                    " (failure injected by TETLOD_MPI_TEST_FAIL_RANK)");
        },
        rank);
    auto closing = run_local([&] { source.reset(); }, rank);
    result.failure = agree(comm, failure ? failure : closing);
    if (result.failure) return result;

    // D: rank 0 encodes with the serial writer, fetching planes as it asks;
    // the others serve them until rank 0 says stop (also after a failure).
    if (rank == 0) {
        DistributedPlanes planes(comm, result.header, slab, partition, traffic);
        failure = run_local([&] { result.summary = write_container(planes, output, o.write); }, rank);
        planes.finish();
    } else {
        failure = run_local([&] { serve_planes(comm, slab, traffic); }, rank);
    }
    result.failure = agree(comm, failure);
    // The encoder's own messages (a NaN sample, say) name a position, not the
    // file: say which conversion it was.
    if (result.failure && result.failure->message.find(file) == std::string::npos &&
        result.failure->message.find(output) == std::string::npos)
        result.failure->message = "'" + input + "': " + result.failure->message;

    // What each rank moved, gathered on rank 0 for the report.
    const double mine[5] = {double(traffic.bytes_read), double(traffic.bytes_sent), double(traffic.bytes_received),
                            double(traffic.messages), traffic.read_seconds};
    std::vector<double> all(rank == 0 ? std::size_t(5) * std::size_t(size) : 0);
    MPI_Gather(mine, 5, MPI_DOUBLE, all.data(), 5, MPI_DOUBLE, 0, comm);
    for (std::size_t r = 0; r * 5 < all.size(); ++r)
        result.traffic.push_back(SlabTraffic{uint64_t(all[r * 5]), uint64_t(all[r * 5 + 1]), uint64_t(all[r * 5 + 2]),
                                             uint64_t(all[r * 5 + 3]), all[r * 5 + 4]});
    return result;
}

}  // namespace tetlod::mpi
