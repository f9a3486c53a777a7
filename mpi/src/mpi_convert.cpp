// The distributed conversion's phases. See mpi_convert.hpp.
#include "mpi_convert.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <sys/resource.h>
#include <unistd.h>

#include "rank_encode.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/core/output_policy.hpp"

namespace tetlod::mpi {

namespace {

// MPI's user operations are plain functions: the sweep whose layout the
// maxima follow is reached through this pointer, set only around the call.
const HtRangeErrors* g_reducing = nullptr;

void merge_maxima_op(void* in, void* inout, int* count, MPI_Datatype*) {
    g_reducing->merge_maxima(static_cast<const std::byte*>(in), static_cast<std::byte*>(inout),
                             std::size_t(*count) * g_reducing->partial_maximum_bytes());
}

/// `maxima` (this rank's partial_maxima()) becomes the maxima over every rank:
/// one MPI_Allreduce with a commutative user operation, so a rank receives
/// about twice the buffer whatever the number of ranks (an MPI_Allgather gave
/// every rank every rank's copy). Collective.
void reduce_maxima(MPI_Comm comm, const HtRangeErrors& errors, std::vector<std::byte>& maxima) {
    const std::size_t each = errors.partial_maximum_bytes();
    const std::size_t count = maxima.size() / each;
    if (count == 0) return;  // the same on every rank: the domain fixes the size
    MPI_Datatype maximum;
    MPI_Type_contiguous(int(each), MPI_BYTE, &maximum);
    MPI_Type_commit(&maximum);
    MPI_Op op;
    MPI_Op_create(&merge_maxima_op, /*commute=*/1, &op);
    g_reducing = &errors;
    MPI_Allreduce(MPI_IN_PLACE, maxima.data(), int(count), maximum, op, comm);
    g_reducing = nullptr;
    MPI_Op_free(&op);
    MPI_Type_free(&maximum);
}

}  // namespace

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

    // The planes of the data box B (the encoder's planes, more than the
    // volume's when padding) are cut into slabs, one per rank.
    const HtDomain domain = HtDomain::for_dims(result.header.dims, o.write.pad);
    const SlabPartition partition{int64_t(domain.box_max[2]) + 1, size};
    const int64_t za = partition.begin(rank), zb = partition.end(rank) - 1;
    // The encoder's own messages (a NaN sample, say) name a position, not the
    // file: say which conversion it was.
    const auto name_conversion = [&](std::optional<RankFailure>& f) {
        if (f && f->message.find(file) == std::string::npos && f->message.find(output) == std::string::npos)
            f->message = "'" + input + "': " + f->message;
    };
    const auto injected = [&](const char* phase, const std::string& what) {
        if (rank == o.fail_rank && o.fail_phase == phase)
            throw Error(ErrorCode::IoError, "'" + file + ":" + dataset + "': " + what +
                                                " (failure injected by TETLOD_MPI_TEST_FAIL_RANK)");
    };

    // C: each rank reads the source planes its slab needs (collective
    // hyperslab reads), then every rank closes the file at this same point
    // (closing is collective too).
    SlabTraffic traffic;
    LocalSlab slab;
    auto failure = run_local(
        [&] {
            slab = read_local_slab(*source, domain, partition, rank, traffic);
            injected("read", "could not read planes " + std::to_string(slab.z0) + ".." +
                                 std::to_string(slab.z0 + slab.planes - 1));
        },
        rank);
    auto closing = run_local([&] { source.reset(); }, rank);
    result.failure = agree(comm, failure ? failure : closing);
    if (result.failure) return result;

    // D: the first pass on every rank over its planes (range, finiteness,
    // coarse lattice); a non-finite sample fails the lowest rank holding one,
    // whose message names the first such sample, as the serial scan's does.
    LocalSlabPlanes local(result.header, slab);
    HtScanPart scan;
    result.failure = run_phase(comm, [&] {
        const double t = MPI_Wtime();
        scan = ht_scan_planes(local, o.write.pad, za, zb);
        traffic.scan_seconds = MPI_Wtime() - t;
        injected("scan", "could not scan planes " + std::to_string(za) + ".." + std::to_string(zb));
    });
    name_conversion(result.failure);
    if (result.failure) return result;
    // Coarse points come from one rank each (the others hold zero bytes), so
    // OR combines them; the extremes are folded in rank order (plane order).
    MPI_Allreduce(MPI_IN_PLACE, scan.coarse.data(), int(scan.coarse.size()), MPI_BYTE, MPI_BOR, comm);
    {
        const double mine[3] = {scan.any ? 1.0 : 0.0, scan.range[0], scan.range[1]};
        std::vector<double> all(std::size_t(3) * std::size_t(size));
        MPI_Allgather(mine, 3, MPI_DOUBLE, all.data(), 3, MPI_DOUBLE, comm);
        HtScanPart total;
        total.coarse = scan.coarse;
        for (int r = 0; r < size; ++r) {
            HtScanPart part;
            part.any = all[std::size_t(r) * 3] != 0;
            part.range = {all[std::size_t(r) * 3 + 1], all[std::size_t(r) * 3 + 2]};
            part.coarse.assign(total.coarse.size(), std::byte{0});
            ht_merge_scan(total, part);
        }
        scan = std::move(total);
    }
    traffic.bytes_sent += scan.coarse.size() + 3 * sizeof(double);

    // E: every rank computes the errors of the diamonds centred in its
    // planes; the large diamonds' partial maxima are reduced over the ranks
    // (a maximum of maxima: exact in any order), then finished.
    std::unique_ptr<HtRangeErrors> errors;
    result.failure = run_phase(comm, [&] {
        errors = std::make_unique<HtRangeErrors>(local, o.write.pad, scan.range, scan.coarse, za, zb);
        const double t = MPI_Wtime();
        errors->compute();
        traffic.error_seconds = MPI_Wtime() - t;
        injected("errors", "could not compute the errors of planes " + std::to_string(za) + ".." + std::to_string(zb));
    });
    if (result.failure) return result;
    {
        std::vector<std::byte> maxima = errors->partial_maxima();
        reduce_maxima(comm, *errors, maxima);
        result.failure = run_phase(comm, [&] {
            errors->merge_partial_maxima(maxima.data(), maxima.size());
            errors->finish();
        });
        traffic.bytes_sent += maxima.size();  // what the rank contributes; MPI's tree moves it
        traffic.bytes_received += maxima.size();
        if (result.failure) return result;
    }

    // F: every rank encodes the rows of bricks starting in its planes (their
    // windows' lattice planes from other slabs come by one MPI_Alltoallv),
    // rank 0 lays the file out from every section's size and checksum (the
    // library's layout, the serial writer's), and every rank writes its
    // sections at their offsets with MPI-IO into a temporary file beside the
    // output, renamed by rank 0 once every rank agreed (else deleted).
    const bool to_file = output != "-";
    int pid = int(::getpid());
    MPI_Bcast(&pid, 1, MPI_INT, 0, comm);
    const std::string written =
        (to_file ? output : std::string("tetlod-mpi-stdout")) + ".tetlod-mpi-" + std::to_string(pid) + ".tmp";
    const HtEncodeOptions encode = container_ht_encode_options(o.write, result.header);
    PlaneExchange exchange;
    result.failure = run_phase(comm, [&] {
        exchange = plan_exchange(domain, encode.brick_log2, partition, rank);
        pack_planes(exchange, local, o.write.pad, *errors);
    });
    if (result.failure) return result;
    exchange_planes(comm, exchange, traffic);
    RankSections sections;
    result.failure = run_phase(comm, [&] {
        const double t = MPI_Wtime();
        sections = encode_rank_rows(domain, encode, local, o.write.pad, *errors, partition, rank, exchange);
        traffic.encode_seconds = MPI_Wtime() - t;
        injected("encode", "could not encode the bricks of planes " + std::to_string(za) + ".." + std::to_string(zb));
    });
    name_conversion(result.failure);
    if (result.failure) return result;
    exchange = {};
    errors.reset();
    RankLayout layout;
    {
        tlod::Metadata meta = container_metadata(result.header, o.write);
        meta.value_range = scan.range;
        result.failure = lay_out(comm, domain, meta, encode, sections, layout, traffic);
    }
    if (result.failure) return result;
    result.failure = write_sections(comm, written, layout, sections, traffic);
    if (result.failure) return result;
    sections = {};
    failure.reset();
    if (rank == 0) {
        failure = run_local(
            [&] {
                std::error_code ec, ignored;
                if (to_file) {
                    std::filesystem::rename(written, output, ec);
                    if (ec) {
                        std::filesystem::remove(written, ignored);
                        throw Error(ErrorCode::IoError, "'" + output +
                                                            "': cannot rename the written container into place: " +
                                                            ec.message());
                    }
                } else {
                    // Standard output: MPI-IO cannot write there; copy the file.
                    std::ifstream in(written, std::ios::binary);
                    std::cout << in.rdbuf();
                    std::cout.flush();
                    in.close();
                    std::filesystem::remove(written, ignored);
                    if (!std::cout) throw Error(ErrorCode::IoError, "cannot write the container to standard output");
                }
            },
            rank);
        result.summary.bytes = to_file ? layout.file_size : 0;
        result.summary.ht_k = domain.k;
        result.summary.ht_max_level = domain.max_level();
    }
    result.failure = agree(comm, failure);
    name_conversion(result.failure);

    // What each rank moved, gathered on rank 0 for the report.
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    traffic.cpu_seconds = double(usage.ru_utime.tv_sec) + 1e-6 * double(usage.ru_utime.tv_usec);
    constexpr int kFields = 10;
    const double mine[kFields] = {double(traffic.bytes_read), double(traffic.bytes_sent),
                                  double(traffic.bytes_received), double(traffic.messages), traffic.read_seconds,
                                  traffic.scan_seconds, traffic.error_seconds, traffic.cpu_seconds,
                                  traffic.encode_seconds, double(traffic.bytes_written)};
    std::vector<double> all(rank == 0 ? std::size_t(kFields) * std::size_t(size) : 0);
    MPI_Gather(mine, kFields, MPI_DOUBLE, all.data(), kFields, MPI_DOUBLE, 0, comm);
    for (std::size_t r = 0; r * kFields < all.size(); ++r) {
        const double* v = all.data() + r * kFields;
        result.traffic.push_back(
            SlabTraffic{uint64_t(v[0]), uint64_t(v[1]), uint64_t(v[2]), uint64_t(v[3]), v[4], v[5], v[6], v[8],
                        uint64_t(v[9]), v[7]});
    }
    return result;
}

}  // namespace tetlod::mpi
