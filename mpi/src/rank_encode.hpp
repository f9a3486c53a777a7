#pragma once
// Encoding on every rank and the collective write (docs/distributed.md §3.6
// step 3). Rank r encodes the rows of bricks whose first plane lies in its
// slab (ht_rows_in): every cycle's rows, so the coarse cycles' few rows go to
// the ranks holding their first planes. A row's coders read the lattice
// planes of its window (ht_row_window), which may lie in other slabs (the
// plane after a cycle-0 row; most of a coarse row): those planes' values and
// errors come from their slab's owner, in one MPI_Alltoallv whose counts every
// rank computes alone (the partition and the rows are known to all). Then the
// sizes and checksums of every section go to rank 0, which lays the file out
// (ht_distributed_layout: the same layout as the serial writer, from the
// library), and every rank writes its sections at their offsets with
// MPI_File_write_at_all into a temporary file.
#include <mpi.h>

#include <optional>
#include <string>
#include <vector>

#include "rank_failure.hpp"
#include "slab_planes.hpp"
#include "tetlod/codecs/ht/ht_distributed.hpp"

namespace tetlod::mpi {

/// A lattice plane: plane z of B on the lattice of cycle t.
struct LatticePlane {
    int t = 0;
    int64_t z = 0;
    bool operator<(const LatticePlane& o) const { return t != o.t ? t < o.t : z < o.z; }
    bool operator==(const LatticePlane& o) const { return t == o.t && z == o.z; }
};

/// The lattice planes rank `consumer`'s rows read that lie in rank
/// `provider`'s slab (none when they are the same rank), sorted.
std::vector<LatticePlane> planes_needed(const HtDomain& domain, int brick_log2, const SlabPartition& partition,
                                        int consumer, int provider);
/// Bytes of one lattice plane as exchanged: its values, then its errors (t < k).
std::size_t lattice_plane_bytes(const HtDomain& domain, ValueType type, int t);

/// What the exchange moves: the planes this rank sends to and receives from
/// each rank, in rank order.
struct PlaneExchange {
    std::vector<std::vector<LatticePlane>> to, from;
    std::vector<std::size_t> to_bytes, from_bytes;  // per rank (pack_planes)
    std::vector<std::byte> sent, received;
};
PlaneExchange plan_exchange(const HtDomain& domain, int brick_log2, const SlabPartition& partition, int rank);
/// Packs the planes `x.to` lists from this rank's slab and errors (local).
void pack_planes(PlaneExchange& x, VolumePlanes& local, bool pad, HtRangeErrors& errors);
/// Collective: the planes go to the ranks that need them (MPI_Alltoallv).
void exchange_planes(MPI_Comm comm, PlaneExchange& x, SlabTraffic& traffic);

/// Encodes this rank's rows (local; values and errors from its slab or `x.received`).
struct RankSections {
    std::vector<HtSection> sections;
    HtRowEncoder::ErrorStats stats;
};
RankSections encode_rank_rows(const HtDomain& domain, const HtEncodeOptions& options, VolumePlanes& local, bool pad,
                              HtRangeErrors& errors, const SlabPartition& partition, int rank,
                              const PlaneExchange& x);

/// Collective: gathers every rank's section entries and error stats on rank 0,
/// which lays the container out (ht_distributed_layout, `meta` with the value
/// range set); each rank gets its sections' offsets, rank 0 also the head.
/// Failures (the layout's checks) are agreed on.
struct RankLayout {
    std::vector<uint64_t> offsets;  // of this rank's sections
    std::vector<std::byte> head;    // rank 0: written at offset 0
    uint64_t file_size = 0;         // every rank
};
std::optional<RankFailure> lay_out(MPI_Comm comm, const HtDomain& domain, const tlod::Metadata& meta,
                                   const HtEncodeOptions& options, const RankSections& mine, RankLayout& layout,
                                   SlabTraffic& traffic);

/// Collective: creates `path` (MPI-IO, must not exist) and writes the head
/// (rank 0) and every rank's sections at their offsets with
/// MPI_File_write_at_all; deletes the file on any rank's failure.
std::optional<RankFailure> write_sections(MPI_Comm comm, const std::string& path, const RankLayout& layout,
                                          const RankSections& mine, SlabTraffic& traffic);

}  // namespace tetlod::mpi
