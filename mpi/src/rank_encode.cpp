// Encoding on every rank and the collective write. See rank_encode.hpp.
#include "rank_encode.hpp"

#include <algorithm>
#include <climits>
#include <cstring>
#include <filesystem>
#include <map>

namespace tetlod::mpi {

namespace {

constexpr std::size_t kMaxCall = std::size_t{1} << 30;  // bytes per MPI call: far below 2 GiB

int checked_int(std::size_t n, const char* what) {
    if (n > std::size_t(INT_MAX))
        throw Error(ErrorCode::TooLarge, std::string("tetlod-mpi: ") + what + " exceeds 2 GiB per rank; use more ranks");
    return int(n);
}

std::string mpi_error_text(int code) {
    char text[MPI_MAX_ERROR_STRING];
    int n = 0;
    MPI_Error_string(code, text, &n);
    return std::string(text, std::size_t(std::max(n, 0)));
}

}  // namespace

std::vector<LatticePlane> planes_needed(const HtDomain& d, int g, const SlabPartition& partition, int consumer,
                                        int provider) {
    std::vector<LatticePlane> out;
    if (consumer == provider) return out;
    const int64_t pa = partition.begin(provider), pb = partition.end(provider) - 1;
    if (pa > pb) return out;
    for (const HtBrickRow& row : ht_rows_in(d, g, partition.begin(consumer), partition.end(consumer) - 1)) {
        const auto w = ht_row_window(d, g, row);
        const int64_t h = int64_t{1} << row.t;
        const int64_t from = std::max(w[0], (pa + h - 1) / h * h), to = std::min(w[1], pb);
        for (int64_t z = from; z <= to; z += h) out.push_back(LatticePlane{row.t, z});
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

std::size_t lattice_plane_bytes(const HtDomain& d, ValueType type, int t) {
    const std::size_t points = std::size_t(ht_lattice_plane_points(d, t));
    return points * value_size(type) + (t < d.k ? points * sizeof(float) : 0);
}

PlaneExchange plan_exchange(const HtDomain& d, int g, const SlabPartition& partition, int rank) {
    PlaneExchange x;
    x.to.resize(std::size_t(partition.ranks));
    x.from.resize(std::size_t(partition.ranks));
    for (int r = 0; r < partition.ranks; ++r) {
        x.to[std::size_t(r)] = planes_needed(d, g, partition, r, rank);
        x.from[std::size_t(r)] = planes_needed(d, g, partition, rank, r);
    }
    return x;
}

void pack_planes(PlaneExchange& x, VolumePlanes& local, bool pad, HtRangeErrors& errors) {
    const HtDomain& d = errors.domain();
    const ValueType type = local.header().type;
    const auto sizes = [&](const std::vector<std::vector<LatticePlane>>& lists, std::vector<std::size_t>& bytes) {
        bytes.assign(lists.size(), 0);
        std::size_t total = 0;
        for (std::size_t r = 0; r < lists.size(); ++r) {
            for (const LatticePlane& p : lists[r]) bytes[r] += lattice_plane_bytes(d, type, p.t);
            total += bytes[r];
        }
        return total;
    };
    const std::size_t total = sizes(x.to, x.to_bytes);
    checked_int(total, "the lattice planes sent to other ranks");
    checked_int(sizes(x.from, x.from_bytes), "the lattice planes received from other ranks");
    x.sent.resize(total);
    std::byte* out = x.sent.data();
    for (const auto& list : x.to)
        for (const LatticePlane& p : list) {
            const std::size_t points = std::size_t(ht_lattice_plane_points(d, p.t));
            ht_lattice_values(local, pad, p.t, p.z, out);
            out += points * value_size(type);
            if (p.t < d.k) {
                std::memcpy(out, errors.error_plane(p.t, p.z), points * sizeof(float));
                out += points * sizeof(float);
            }
        }
}

void exchange_planes(MPI_Comm comm, PlaneExchange& x, SlabTraffic& traffic) {
    const std::size_t ranks = x.to.size();
    std::vector<int> scount(ranks), sdispl(ranks), rcount(ranks), rdispl(ranks);
    std::size_t so = 0, ro = 0;
    for (std::size_t r = 0; r < ranks; ++r) {
        scount[r] = int(x.to_bytes[r]);
        sdispl[r] = int(so);
        so += x.to_bytes[r];
        rcount[r] = int(x.from_bytes[r]);
        rdispl[r] = int(ro);
        ro += x.from_bytes[r];
        traffic.messages += (x.to_bytes[r] > 0) + (x.from_bytes[r] > 0);
    }
    x.received.resize(ro);
    MPI_Alltoallv(x.sent.data(), scount.data(), sdispl.data(), MPI_BYTE, x.received.data(), rcount.data(),
                  rdispl.data(), MPI_BYTE, comm);
    traffic.bytes_sent += so;
    traffic.bytes_received += ro;
    x.sent = {};
}

RankSections encode_rank_rows(const HtDomain& d, const HtEncodeOptions& o, VolumePlanes& local, bool pad,
                              HtRangeErrors& errors, const SlabPartition& partition, int rank,
                              const PlaneExchange& x) {
    const ValueType type = local.header().type;
    const std::size_t vs = value_size(type);
    // Where each received plane lies (the ranks' parts in rank order, planes in list order).
    std::map<LatticePlane, const std::byte*> received;
    const std::byte* in = x.received.data();
    for (const auto& list : x.from)
        for (const LatticePlane& p : list) {
            received[p] = in;
            in += lattice_plane_bytes(d, type, p.t);
        }
    RankSections out;
    HtRowEncoder encoder(d, type, o);
    std::vector<std::byte> values;
    std::vector<float> errs;
    for (const HtBrickRow& row : ht_rows_in(d, o.brick_log2, partition.begin(rank), partition.end(rank) - 1)) {
        const auto w = ht_row_window(d, o.brick_log2, row);
        const int t = row.t;
        const int64_t h = int64_t{1} << t, planes = ((w[1] - w[0]) >> t) + 1;
        const std::size_t points = std::size_t(ht_lattice_plane_points(d, t));
        const bool with_errors = t < d.k;
        values.resize(std::size_t(planes) * points * vs);
        errs.resize(with_errors ? std::size_t(planes) * points : 0);
        for (int64_t i = 0, z = w[0]; i < planes; ++i, z += h) {
            std::byte* v = values.data() + std::size_t(i) * points * vs;
            float* e = with_errors ? errs.data() + std::size_t(i) * points : nullptr;
            if (partition.owner(z) == rank) {
                ht_lattice_values(local, pad, t, z, v);
                if (e) std::memcpy(e, errors.error_plane(t, z), points * sizeof(float));
                continue;
            }
            const auto it = received.find(LatticePlane{t, z});
            if (it == received.end())
                throw Error(ErrorCode::InvalidArgument, "tetlod-mpi: a lattice plane of a row was not received");
            std::memcpy(v, it->second, points * vs);
            if (e) std::memcpy(e, it->second + points * vs, points * sizeof(float));
        }
        encoder.encode(row, values.data(), with_errors ? errs.data() : nullptr, out.sections);
    }
    out.stats = encoder.error_stats();
    return out;
}

std::optional<RankFailure> lay_out(MPI_Comm comm, const HtDomain& d, const tlod::Metadata& meta,
                                   const HtEncodeOptions& o, const RankSections& mine, RankLayout& layout,
                                   SlabTraffic& traffic) {
    int rank = 0, ranks = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &ranks);
    constexpr int kFields = 7;
    std::vector<uint64_t> entries;
    entries.reserve(mine.sections.size() * kFields);
    for (const HtSection& s : mine.sections)
        entries.insert(entries.end(), {s.type, s.flags, s.cycle, s.brick, uint64_t(s.bytes.size()), s.raw_size,
                                       s.checksum});
    // Counts in entries (each kFields values); checked against int before any collective.
    int count = int(std::min<std::size_t>(mine.sections.size(), INT_MAX / kFields));
    std::vector<int> counts(std::size_t(rank == 0 ? ranks : 0));
    MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
    std::vector<int> vcounts, displs;
    std::size_t total = 0;
    if (rank == 0) {
        for (int c : counts) {
            vcounts.push_back(c * kFields);
            displs.push_back(int(std::min<std::size_t>(total * kFields, INT_MAX)));
            total += std::size_t(c);
        }
    }
    auto failure = run_local(
        [&] {
            if (mine.sections.size() > std::size_t(count) || total * kFields > std::size_t(INT_MAX))
                throw Error(ErrorCode::TooLarge, "tetlod-mpi: too many chunk sections for one gather; use larger bricks");
        },
        rank);
    if ((failure = agree(comm, failure))) return failure;
    std::vector<uint64_t> all(rank == 0 ? total * kFields : 0);
    MPI_Gatherv(entries.data(), count * kFields, MPI_UINT64_T, all.data(), vcounts.data(), displs.data(),
                MPI_UINT64_T, 0, comm);
    traffic.bytes_sent += entries.size() * sizeof(uint64_t);
    if (rank == 0) traffic.bytes_received += (all.size() - entries.size()) * sizeof(uint64_t);
    HtRowEncoder::ErrorStats stats;
    uint64_t always = mine.stats.always_split;
    MPI_Reduce(&mine.stats.raw_max, &stats.raw_max, 1, MPI_FLOAT, MPI_MAX, 0, comm);
    MPI_Reduce(&always, &stats.always_split, 1, MPI_UINT64_T, MPI_SUM, 0, comm);

    std::vector<uint64_t> offsets;
    failure = run_local(
        [&] {
            if (rank != 0) return;
            std::vector<HtSectionEntry> list(total);
            for (std::size_t i = 0; i < total; ++i) {
                const uint64_t* v = all.data() + i * kFields;
                list[i] = HtSectionEntry{uint32_t(v[0]), uint32_t(v[1]), uint32_t(v[2]), uint32_t(v[3]),
                                         v[4], v[5], v[6]};
            }
            HtContainerLayout l = ht_distributed_layout(d, meta, stats, o, list);
            layout.head = std::move(l.head);
            layout.file_size = l.file_size;
            offsets = std::move(l.offsets);
        },
        rank);
    if ((failure = agree(comm, failure))) return failure;
    layout.offsets.resize(mine.sections.size());
    std::vector<int> odispl;
    if (rank == 0) {
        std::size_t at = 0;
        for (int c : counts) {
            odispl.push_back(int(at));
            at += std::size_t(c);
        }
    }
    MPI_Scatterv(offsets.data(), counts.data(), odispl.data(), MPI_UINT64_T, layout.offsets.data(), count,
                 MPI_UINT64_T, 0, comm);
    MPI_Bcast(&layout.file_size, 1, MPI_UINT64_T, 0, comm);
    return std::nullopt;
}

std::optional<RankFailure> write_sections(MPI_Comm comm, const std::string& path, const RankLayout& layout,
                                          const RankSections& mine, SlabTraffic& traffic) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    // Runs of adjacent sections (a rank's rows of a cycle are one run), cut into
    // pieces of at most kMaxCall bytes, each written by one collective call.
    struct Run {
        uint64_t offset = 0;
        std::size_t first = 0, last = 0;  // sections [first, last); rank 0's head: first == last == npos
        uint64_t bytes = 0;
    };
    constexpr std::size_t kHead = std::size_t(-1);
    std::vector<Run> runs;
    if (rank == 0 && !layout.head.empty()) runs.push_back(Run{0, kHead, kHead, layout.head.size()});
    for (std::size_t i = 0; i < mine.sections.size(); ++i) {
        const uint64_t size = mine.sections[i].bytes.size();
        if (!runs.empty() && runs.back().first != kHead && runs.back().offset + runs.back().bytes == layout.offsets[i]) {
            runs.back().last = i + 1;
            runs.back().bytes += size;
        } else {
            runs.push_back(Run{layout.offsets[i], i, i + 1, size});
        }
    }
    // Empty sections (the corner cycle's error sections) write nothing.
    runs.erase(std::remove_if(runs.begin(), runs.end(), [](const Run& r) { return r.bytes == 0; }), runs.end());
    long long pieces = 0;
    for (const Run& r : runs) pieces += (long long)((r.bytes + kMaxCall - 1) / kMaxCall);
    long long calls = 0;
    MPI_Allreduce(&pieces, &calls, 1, MPI_LONG_LONG, MPI_MAX, comm);

    MPI_File fh = MPI_FILE_NULL;
    const int rc = MPI_File_open(comm, path.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY | MPI_MODE_EXCL, MPI_INFO_NULL,
                                 &fh);
    std::optional<RankFailure> failure;
    if (rc != MPI_SUCCESS)
        failure = RankFailure{ErrorCode::IoError, "'" + path + "': cannot create: " + mpi_error_text(rc), rank, false};
    int opened_here = rc == MPI_SUCCESS ? 1 : 0, opened_all = 0;
    MPI_Allreduce(&opened_here, &opened_all, 1, MPI_INT, MPI_MIN, comm);
    if (!opened_all) {
        // MPI_File_close is collective: only when every rank opened the file.
        std::optional<RankFailure> agreed = agree(comm, failure);
        if (rank == 0) {
            std::error_code ignored;
            std::filesystem::remove(path, ignored);
        }
        return agreed;
    }

    std::vector<std::byte> staging;
    std::size_t run = 0;
    uint64_t done_in_run = 0;
    for (long long call = 0; call < calls; ++call) {
        const std::byte* data = nullptr;
        int n = 0;
        MPI_Offset at = 0;
        if (run < runs.size()) {
            const Run& r = runs[run];
            if (done_in_run == 0 && r.first != kHead) {
                staging.clear();
                staging.reserve(r.bytes);
                for (std::size_t i = r.first; i < r.last; ++i)
                    staging.insert(staging.end(), mine.sections[i].bytes.begin(), mine.sections[i].bytes.end());
            }
            const std::byte* base = r.first == kHead ? layout.head.data() : staging.data();
            n = int(std::min<uint64_t>(kMaxCall, r.bytes - done_in_run));
            data = base + done_in_run;
            at = MPI_Offset(r.offset + done_in_run);
            done_in_run += uint64_t(n);
            if (done_in_run == r.bytes) ++run, done_in_run = 0;
        }
        MPI_Status status;
        const int w = MPI_File_write_at_all(fh, at, data, n, MPI_BYTE, &status);
        int written = 0;
        if (w == MPI_SUCCESS) MPI_Get_count(&status, MPI_BYTE, &written);
        if (!failure && (w != MPI_SUCCESS || written != n))
            failure = RankFailure{ErrorCode::IoError,
                                  "'" + path + "': cannot write " + std::to_string(n) + " bytes at offset " +
                                      std::to_string(at) + (w != MPI_SUCCESS ? ": " + mpi_error_text(w) : ""),
                                  rank, false};
        traffic.bytes_written += uint64_t(n);
    }
    const int c = MPI_File_close(&fh);
    if (!failure && c != MPI_SUCCESS)
        failure = RankFailure{ErrorCode::IoError, "'" + path + "': cannot close: " + mpi_error_text(c), rank, false};
    failure = agree(comm, failure);
    if (failure && rank == 0) {
        std::error_code ignored;
        std::filesystem::remove(path, ignored);
    }
    return failure;
}

}  // namespace tetlod::mpi
