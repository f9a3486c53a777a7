// The distributed extraction's phases. See mpi_extract.hpp.
#include "mpi_extract.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <memory>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/core/output_policy.hpp"
#include "tetlod/format/container.hpp"

namespace tetlod::mpi {

namespace {

/// A run of tets with their levels and errors (what a sink's add() gets).
struct TetRun {
    std::vector<std::array<uint32_t, 4>> tets;
    std::vector<uint8_t> level;
    std::vector<float> error;
};

/// The sink of a rank other than 0: its run is kept (its share of the output)
/// until the ranks agree that all of them emitted theirs; the vertices, which
/// rank 0 writes, are not kept. In batches of at most kBatchTets: one growing
/// vector would hold up to twice the run while it reallocates, and the
/// emitter's own batches can be a few dozen tets, each of which would cost
/// four messages to send.
class RunKeeper final : public TetMeshSink {
public:
    static constexpr std::size_t kBatchTets = std::size_t{1} << 18;  // 5.5 MB
    void begin(const TetMesh& vertices, uint64_t tet_count) override {
        vertices_ = vertices.points.size();
        total_ = tet_count;
    }
    void add(std::span<const std::array<uint32_t, 4>> t, std::span<const uint8_t> l,
             std::span<const float> e) override {
        for (std::size_t at = 0; at < t.size();) {
            if (batches.empty() || batches.back().tets.size() >= kBatchTets) batches.emplace_back();
            TetRun& b = batches.back();
            const std::size_t k = std::min(t.size() - at, kBatchTets - b.tets.size());
            b.tets.insert(b.tets.end(), t.begin() + at, t.begin() + at + k);
            b.level.insert(b.level.end(), l.begin() + at, l.begin() + at + k);
            b.error.insert(b.error.end(), e.begin() + at, e.begin() + at + k);
            at += k;
        }
        tets_ += t.size();
    }
    void finish() override {}
    std::vector<TetRun> batches;
    uint64_t vertices_ = 0, total_ = 0, tets_ = 0;
};

/// Rank 0's sink: the file writer gets the vertices and rank 0's run as they
/// come; its finish() is held back until the other ranks' runs are appended.
class HeldWriter final : public TetMeshSink {
public:
    explicit HeldWriter(TetMeshSink& to) : to_(to) {}
    void begin(const TetMesh& vertices, uint64_t tet_count) override {
        vertices_ = vertices.points.size();
        total_ = tet_count;
        to_.begin(vertices, tet_count);
    }
    void add(std::span<const std::array<uint32_t, 4>> t, std::span<const uint8_t> l,
             std::span<const float> e) override {
        tets_ += t.size();
        to_.add(t, l, e);
    }
    void finish() override {}
    uint64_t vertices_ = 0, total_ = 0, tets_ = 0;

private:
    TetMeshSink& to_;
};

/// Rank r > 0: its run to rank 0, as the number of pieces, then each piece's
/// size, tets, levels and errors (batches cut into pieces of at most `piece`
/// tets, so every message stays far below MPI's 2^31 count). Each batch is
/// released once sent. Counts what it sends in `traffic`.
void send_run(MPI_Comm comm, std::vector<TetRun>& batches, std::size_t piece, ExtractTraffic& traffic) {
    uint64_t pieces = 0;
    for (const TetRun& b : batches) pieces += (b.tets.size() + piece - 1) / piece;
    MPI_Send(&pieces, 1, MPI_UINT64_T, 0, 0, comm);
    traffic.messages += 1;
    traffic.bytes_sent += sizeof pieces;
    for (TetRun& run : batches) {
        for (std::size_t b = 0; b < run.tets.size(); b += piece) {
            const std::size_t k = std::min(piece, run.tets.size() - b);
            uint64_t n = k;
            MPI_Send(&n, 1, MPI_UINT64_T, 0, 0, comm);
            MPI_Send(run.tets.data() + b, int(k * 16), MPI_BYTE, 0, 1, comm);
            MPI_Send(run.level.data() + b, int(k), MPI_BYTE, 0, 2, comm);
            MPI_Send(run.error.data() + b, int(k * 4), MPI_BYTE, 0, 3, comm);
            traffic.messages += 4;
            traffic.bytes_sent += sizeof n + k * 21;
        }
        run = TetRun{};
    }
}

/// Rank 0: the run of rank `from`, piece by piece into `to` (nullptr: received
/// and dropped, after a failure, so the sender is not left blocked). Counts
/// what it receives in `traffic`.
void receive_run(MPI_Comm comm, int from, TetMeshSink* to, ExtractTraffic& traffic) {
    uint64_t pieces = 0;
    MPI_Recv(&pieces, 1, MPI_UINT64_T, from, 0, comm, MPI_STATUS_IGNORE);
    traffic.messages += 1;
    traffic.bytes_received += sizeof pieces;
    TetRun buf;
    for (uint64_t p = 0; p < pieces; ++p) {
        uint64_t k = 0;
        MPI_Recv(&k, 1, MPI_UINT64_T, from, 0, comm, MPI_STATUS_IGNORE);
        buf.tets.resize(k);
        buf.level.resize(k);
        buf.error.resize(k);
        MPI_Recv(buf.tets.data(), int(k * 16), MPI_BYTE, from, 1, comm, MPI_STATUS_IGNORE);
        MPI_Recv(buf.level.data(), int(k), MPI_BYTE, from, 2, comm, MPI_STATUS_IGNORE);
        MPI_Recv(buf.error.data(), int(k * 4), MPI_BYTE, from, 3, comm, MPI_STATUS_IGNORE);
        traffic.messages += 4;
        traffic.bytes_received += sizeof k + k * 21;
        if (to) to->add(buf.tets, buf.level, buf.error);
    }
}

double cpu_seconds(double* peak_rss_mb) {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    *peak_rss_mb = double(usage.ru_maxrss) / 1024.0;
    return double(usage.ru_utime.tv_sec) + 1e-6 * double(usage.ru_utime.tv_usec);
}

}  // namespace

MpiExtractResult extract_mpi(MPI_Comm comm, const std::string& input, const std::string& output,
                             const MpiExtractOptions& o) {
    int rank = 0, size = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
    MpiExtractResult result;
    // Rank 0 owns the output: the policy (an existing file without force, the
    // input itself) is consulted there, when the writer is opened.
    OutputPolicy policy;
    policy.force = o.force;
    policy.force_hint = "use -f/--force to overwrite it";
    policy.add_input(input);
    std::optional<ScopedOutputPolicy> scope;
    if (rank == 0) scope.emplace(policy);
    const auto name_input = [&](std::optional<RankFailure>& f) {
        if (f && f->message.find(input) == std::string::npos && f->message.find(output) == std::string::npos)
            f->message = "'" + input + "': " + f->message;
    };

    // A: rank 0 opens the writer first (a refused output costs no work), then
    // every rank refines and emits its run. Rank 0's run streams into the
    // file; the others keep theirs.
    std::unique_ptr<TetMeshSink> file;
    std::unique_ptr<HeldWriter> held;
    RunKeeper kept;
    ExtractTraffic mine;
    result.failure = run_phase(comm, [&] {
        if (rank == 0) {
            file = open_mesh_stream(output, o.format, o.write);
            held = std::make_unique<HeldWriter>(*file);
        }
    });
    if (result.failure) return result;
    result.failure = run_phase(comm, [&] {
        tlod::ContainerReader reader = tlod::ContainerReader::open(input).take();
        if ((reader.header().required_features & tlod::kFeatureHt) == 0)
            throw Error(ErrorCode::UnsupportedFeature,
                        "'" + input + "' holds no HT model (an MT only, extracted whole): use `tetlod extract`");
        const HtLayout layout = read_ht_layout(reader).take();
        result.dims = layout.metadata.dims;
        result.type = layout.metadata.type;
        result.range = layout.metadata.value_range;
        LodQuery query = o.query;
        if (o.resolve) o.resolve(query, result.range);
        HtEmitShare share{rank, size, /*vertex_values=*/rank == 0};
        HtExtractStats stats;
        HtLazyStats lazy;
        HtLazyOptions lo;
        lo.cache_bytes = o.cache_bytes;
        TetMeshSink& sink = rank == 0 ? static_cast<TetMeshSink&>(*held) : kept;
        extract_ht_lazy_to(reader, query, sink, &stats, &lazy, lo, share).take();
        mine.tets = rank == 0 ? held->tets_ : kept.tets_;
        mine.chunks_decoded = lazy.chunks_decoded;
        mine.refine_seconds = stats.refine_seconds;
        mine.emit_seconds = stats.emit_seconds;
        result.max_error = stats.max_error;
        result.tets = rank == 0 ? held->total_ : kept.total_;
        result.vertices = rank == 0 ? held->vertices_ : kept.vertices_;
        if (rank == o.fail_rank)
            throw Error(ErrorCode::CorruptData, "'" + input + "': test failure injected after the run of rank " +
                                                    std::to_string(rank));
    });
    name_input(result.failure);
    if (result.failure) return result;  // rank 0's writer, destroyed uncommitted, leaves no file

    // B: the runs of ranks 1.. to rank 0 in rank order, appended to the file,
    // which is then committed. Rank 0 receives every run even after a failed
    // append, so no sender is left waiting.
    result.failure = agree(comm, run_local(
                                     [&] {
                                         if (rank != 0) {
                                             send_run(comm, kept.batches, o.message_tets, mine);
                                             return;
                                         }
                                         std::optional<RankFailure> first;
                                         for (int r = 1; r < size; ++r) {
                                             auto f = run_local([&] { receive_run(comm, r, first ? nullptr : held.get(), mine); }, 0);
                                             if (f && !first) first = f;
                                         }
                                         if (first) throw Error(first->code, first->message);
                                         file->finish();
                                     },
                                     rank));
    if (result.failure) return result;

    double peak = 0;
    mine.cpu_seconds = cpu_seconds(&peak);
    mine.peak_rss_mb = peak;
    double max_error = result.max_error;
    MPI_Allreduce(&max_error, &result.max_error, 1, MPI_DOUBLE, MPI_MAX, comm);
    constexpr int kFields = 9;  // doubles hold these counts exactly (below 2^53)
    const double row[kFields] = {double(mine.tets),       double(mine.chunks_decoded), double(mine.bytes_sent),
                                 double(mine.bytes_received), double(mine.messages),  mine.refine_seconds,
                                 mine.emit_seconds,       mine.cpu_seconds,            mine.peak_rss_mb};
    std::vector<double> rows(rank == 0 ? std::size_t(size) * kFields : 0);
    MPI_Gather(row, kFields, MPI_DOUBLE, rows.data(), kFields, MPI_DOUBLE, 0, comm);
    for (int r = 0; rank == 0 && r < size; ++r) {
        const double* x = rows.data() + std::size_t(r) * kFields;
        result.traffic.push_back({uint64_t(x[0]), uint64_t(x[1]), uint64_t(x[2]), uint64_t(x[3]), uint64_t(x[4]),
                                  x[5], x[6], x[7], x[8]});
    }
    return result;
}

}  // namespace tetlod::mpi
