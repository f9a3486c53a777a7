// The distributed decode's phases. See mpi_decode.hpp.
#include "mpi_decode.hpp"

#include <algorithm>
#include <cctype>
#include <memory>

#include <sys/resource.h>

#include "mpi_convert.hpp"  // split_hdf5_location
#include "row_slabs.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/converters/hdf5.hpp"
#include "tetlod/converters/hdf5_mpi_write.hpp"
#include "tetlod/core/output_policy.hpp"
#include "tetlod/format/container.hpp"

namespace tetlod::mpi {

namespace {

bool has_hdf5_extension(const std::string& file) {
    std::string lower = file;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    for (const std::string ext : {".h5", ".hdf5", ".he5"})
        if (lower.size() > ext.size() && lower.compare(lower.size() - ext.size(), ext.size(), ext) == 0) return true;
    return false;
}

// The container's plane decoder and the height of its rows of finest bricks.
struct ContainerPlanes {
    std::unique_ptr<VolumePlanes> planes;
    int64_t row = 1;
};

ContainerPlanes open_planes(const std::string& input) {
    tlod::ContainerReader reader = tlod::ContainerReader::open(input).take();
    if ((reader.header().required_features & tlod::kFeatureHt) == 0)
        throw Error(ErrorCode::UnsupportedFeature,
                    "'" + input + "' holds no HT model (an MT only, decoded whole): use `tetlod decode`");
    ContainerPlanes c;
    c.row = int64_t{1} << (1 + read_ht_layout(reader).take().brick_log2);
    c.planes = open_ht_planes(std::move(reader)).take();
    return c;
}

void broadcast(MPI_Comm comm, std::string& s) {
    uint64_t n = s.size();
    MPI_Bcast(&n, 1, MPI_UINT64_T, 0, comm);
    s.resize(std::size_t(n));
    if (n > 0) MPI_Bcast(s.data(), int(n), MPI_CHAR, 0, comm);
}

}  // namespace

MpiDecodeResult decode_mpi(MPI_Comm comm, const std::string& input, const std::string& output,
                           const MpiDecodeOptions& o) {
    int rank = 0, size = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
    MpiDecodeResult result;
    const auto location = split_hdf5_location(output);
    const std::string& file = location.first;
    const std::string dataset = location.second.empty() ? "/volume" : location.second;  // the serial default

    // Rank 0 owns the output: the policy (refusing an existing dataset
    // without force, the input itself) is consulted there only.
    OutputPolicy policy;
    policy.force = o.force;
    policy.force_hint = "use -f/--force to overwrite it";
    std::optional<ScopedOutputPolicy> scope;
    if (rank == 0) scope.emplace(policy);
    // Messages of the decoder name the container; those that name neither
    // file get the container's name.
    const auto name_files = [&](std::optional<RankFailure>& f) {
        if (f && f->message.find(input) == std::string::npos && f->message.find(file) == std::string::npos)
            f->message = "'" + input + "': " + f->message;
    };

    // A: local, no collective call yet: every rank opens the container (a
    // corrupt header or table fails on every rank); rank 0 checks the output
    // and stages the temporary file it will be written into.
    ContainerPlanes source;
    std::unique_ptr<Hdf5MpiStaging> staging;
    result.failure = run_phase(comm, [&] {
        if (!has_hdf5_extension(file))
            throw Error(ErrorCode::InvalidArgument, "'" + output +
                                                        "': tetlod-mpi decode writes HDF5 only: give FILE.h5:/dataset");
        source = open_planes(input);
        if (rank == 0) {
            policy.add_input(input);
            staging = std::make_unique<Hdf5MpiStaging>(file, dataset);
        }
    });
    name_files(result.failure);
    if (result.failure) return result;
    result.header = source.planes->header();
    result.lost_keys = hdf5_unstorable_keys(result.header);
    std::string temp = rank == 0 ? staging->temp_path() : std::string();
    int update = rank == 0 && staging->update() ? 1 : 0;
    broadcast(comm, temp);
    MPI_Bcast(&update, 1, MPI_INT, 0, comm);

    // B: every rank opens the staged file with the MPI-IO driver and the
    // dataset is created (collective metadata operations, the serial code).
    std::unique_ptr<Hdf5MpiDatasetWriter> writer;
    result.failure = run_phase(comm, [&] {
        writer = create_hdf5_mpi(temp, update != 0, file, dataset, result.header, comm);
    });
    if (result.failure) return result;  // staging (rank 0) removes the temporary file

    // C: each rank decodes its slab in batches and writes each batch by a
    // collective hyperslab write. The ranks agree after every decode, before
    // the write, so a rank that fails (a corrupt chunk) never leaves the
    // others inside MPI-IO; every rank makes the same number of writes.
    const Dims dims = result.header.dims;
    const RowSlabs slabs{dims.z, source.row, size};
    DecodeTraffic traffic;
    traffic.z0 = slabs.begin(rank);
    traffic.planes = slabs.count(rank);
    const std::size_t plane = std::size_t(dims.x) * std::size_t(dims.y) * value_size(result.header.type);
    const int64_t per = std::clamp<int64_t>(int64_t(o.batch_bytes / plane), 1, std::max<int64_t>(1, dims.z));
    const int64_t rounds = (slabs.largest() + per - 1) / per;
    std::vector<std::byte> batch;
    for (int64_t i = 0; i < rounds && !result.failure; ++i) {
        const int64_t z0 = std::min(traffic.z0 + i * per, traffic.z0 + traffic.planes);
        const int64_t n = std::min(per, traffic.z0 + traffic.planes - z0);
        result.failure = run_phase(comm, [&] {
            if (rank == o.fail_rank)
                throw Error(ErrorCode::IoError, "'" + input + "': could not decode planes " + std::to_string(z0) +
                                                    ".. (failure injected by TETLOD_MPI_TEST_FAIL_RANK)");
            const double t = MPI_Wtime();
            batch.resize(std::size_t(n) * plane);
            if (n > 0) source.planes->read(z0, n, batch.data());
            traffic.decode_seconds += MPI_Wtime() - t;
        });
        name_files(result.failure);
        if (result.failure) break;
        result.failure = run_phase(comm, [&] {
            const double t = MPI_Wtime();
            writer->write_planes(z0, n, batch.data());
            traffic.write_seconds += MPI_Wtime() - t;
            traffic.bytes_written += uint64_t(n) * plane;
        });
    }
    batch = {};
    source.planes.reset();

    // D: attributes and close (collective), then rank 0 renames the file into
    // place once every rank agreed. On any failure every rank closes the file
    // here, at the same point, and rank 0's staging removes it.
    if (!result.failure) result.failure = run_phase(comm, [&] { writer->finish(); });
    auto closing = run_local([&] { writer.reset(); }, rank);
    if (!result.failure) result.failure = agree(comm, closing);
    if (!result.failure) {
        result.failure = run_phase(comm, [&] {
            if (rank == 0) staging->commit();
        });
    }
    staging.reset();
    if (result.failure) return result;

    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    traffic.cpu_seconds = double(usage.ru_utime.tv_sec) + 1e-6 * double(usage.ru_utime.tv_usec);
    traffic.peak_rss_mb = double(usage.ru_maxrss) / 1024.0;
    constexpr int kFields = 7;
    const double mine[kFields] = {double(traffic.z0),      double(traffic.planes),        double(traffic.bytes_written),
                                  traffic.decode_seconds, traffic.write_seconds,         traffic.cpu_seconds,
                                  traffic.peak_rss_mb};
    std::vector<double> all(rank == 0 ? std::size_t(kFields) * std::size_t(size) : 0);
    MPI_Gather(mine, kFields, MPI_DOUBLE, all.data(), kFields, MPI_DOUBLE, 0, comm);
    for (std::size_t r = 0; r * kFields < all.size(); ++r) {
        const double* v = all.data() + r * kFields;
        result.traffic.push_back(
            DecodeTraffic{int64_t(v[0]), int64_t(v[1]), uint64_t(v[2]), v[3], v[4], v[5], v[6]});
    }
    return result;
}

}  // namespace tetlod::mpi
