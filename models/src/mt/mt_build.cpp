// MT build: the volume is decimated in bricks, in passes of growing bricks, in the
// spirit of out-of-core simplification (Lindstrom, "Out-of-core simplification of
// large polygonal models", SIGGRAPH 2000; Cignoni et al., "External memory management
// and simplification of huge meshes", TVCG 2003), but with exact errors and a valid MT
// (docs/mt.md §2, "Bricks"). Pass 0 decimates bricks of `brick_cells` cells with their
// inner faces frozen; each later pass has bricks about twice as large whose faces lie
// inside the previous pass's bricks (mt_brick_passes.hpp), which unfreezes the old
// faces; the last pass is one brick, the whole volume.
//
// Determinism: a brick's result depends only on its input (mt_decimate.hpp), and the
// results are merged in brick raster order, so the model is the same for any number of
// threads. With one brick (the volume has at most brick_cells cells per axis, or
// brick_cells = 0) the build is the single global decimation of earlier versions.
#include <algorithm>
#include <cmath>
#include <atomic>
#include <bit>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <condition_variable>
#include <malloc.h>
#include <mutex>
#include <optional>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "mt_brick_passes.hpp"
#include "mt_build_progress.hpp"
#include "mt_decimate.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

/// Appends `count` bits of `src` at bit offset `at` of `dst` (which has exactly `at` bits).
void append_bits(std::vector<uint64_t>& dst, uint64_t at, const std::vector<uint64_t>& src, uint64_t count) {
    dst.resize(size_t((at + count + 63) / 64), 0);
    const uint64_t shift = at & 63;
    for (uint64_t i = 0; i * 64 < count; ++i) {
        uint64_t word = src[i];
        if (count - i * 64 < 64) word &= (uint64_t(1) << (count - i * 64)) - 1;
        const uint64_t pos = (at >> 6) + i;
        dst[pos] |= word << shift;
        if (shift != 0 && pos + 1 < dst.size()) dst[pos + 1] |= word >> (64 - shift);
    }
}

/// Hands the heap's free pages back to the system. A brick's arrays are freed in the
/// arena of the thread that ran it, and glibc keeps such memory for that arena's later
/// use: with bricks of growing size on several threads the resident size then climbs to
/// the sum of every arena's largest brick (bucky 128^3: 410 MB resident for 266 MB ever
/// in use at once). Trimming after each brick keeps the resident size near the live data.
void release_free_heap() {
#if defined(__GLIBC__)
    ::malloc_trim(0);
#endif
}

/// TETLOD_MT_STATS: what the decimation of a pass (or the build) did, per collapse.
void print_stats(const char* what, const mt::BrickResult::Stats& s) {
    const double c = s.commits > 0 ? double(s.commits) : 1.0, e = s.evaluations > 0 ? double(s.evaluations) : 1.0;
    std::fprintf(stderr,
                 "mt build: %s: %llu collapses (%llu reusing their evaluation), %llu evaluations (%.2f per "
                 "collapse, %llu + %llu skipped, %.1f%% cut at the link), %.1f star tets, %.1f targets ranked, %.2f tried, "
                 "%.1f points gathered, %.1f located per evaluation, %llu target walks on several threads, %llu compactions of the point blocks\n",
                 what, (unsigned long long)s.commits, (unsigned long long)s.commits_reused,
                 (unsigned long long)s.evaluations, double(s.evaluations) / c, (unsigned long long)s.skipped, (unsigned long long)s.repeated, 100.0 * double(s.cut_at_link) / e,
                 double(s.star_tets) / e, double(s.ranked) / e, double(s.tried) / e, double(s.gathered) / e,
                 double(s.located) / e, (unsigned long long)s.parallel_walks, (unsigned long long)s.compactions);
}

/// Error cap of pass `pass` of `passes` (never the last, which has none): `top` of the
/// value range for the last-but-one pass, divided by 8 for each pass before it.
double pass_error_cap(int pass, int passes, double range_span, double top) {
    return range_span * top * std::pow(8.0, -(passes - 2 - pass));
}

/// Bytes per grid point of the volume that the bricks running at once may hold
/// together (brick_working_bytes); a brick alone is always admitted. Pass 1 of a volume
/// that pass 0 could not decimate much has a few large bricks (generated 129³: about
/// 680 k tets, ~70 MB each, for 2.1 M points): two of them at once set the build's
/// peak, so they run one after the other. Smaller bricks still run side by side
/// (bucky 128³'s pass 1: ~30 MB each). Results do not depend on it: they are merged in
/// brick order.
constexpr size_t kBrickBudgetPerPoint = 48;

/// The budget never falls below this: on a small volume 48 B per point is less than two
/// bricks of 32 cells (about 9.6 MB each fresh), so neghip 64³ (12.6 MB) and headsq
/// (18.3 MB) ran their first pass one brick at a time on an idle second core. A
/// constant floor costs large volumes nothing, and a small one at most one more brick.
constexpr size_t kBrickBudgetFloor = size_t(32) << 20;

/// Lets a brick start when the bricks running leave room for it in the budget.
class BrickAdmission {
public:
    explicit BrickAdmission(size_t budget) : budget_(budget) {}
    /// Holds `bytes` of the budget from construction to destruction (also when the
    /// brick throws: the others must not wait for it).
    class Ticket {
    public:
        Ticket(BrickAdmission& a, size_t bytes) : a_(a), bytes_(bytes) { a_.enter(bytes_); }
        ~Ticket() { a_.leave(bytes_); }
        Ticket(const Ticket&) = delete;
        Ticket& operator=(const Ticket&) = delete;

    private:
        BrickAdmission& a_;
        size_t bytes_;
    };

private:
    void enter(size_t bytes) {
        std::unique_lock<std::mutex> lock(m_);
        ready_.wait(lock, [&] { return running_ == 0 || held_ + bytes <= budget_; });
        held_ += bytes, ++running_;
    }
    void leave(size_t bytes) {
        {
            std::lock_guard<std::mutex> lock(m_);
            held_ -= bytes, --running_;
        }
        ready_.notify_all();
    }

    std::mutex m_;
    std::condition_variable ready_;
    size_t budget_, held_ = 0;
    int running_ = 0;
};

}  // namespace

MtModel MtModel::build(Volume volume, const MtBuildOptions& options) {
    validate_dims(volume.dims, "MT volume");
    if (volume.dims.x < 2 || volume.dims.y < 2 || volume.dims.z < 2)
        throw Error(ErrorCode::InvalidArgument, "MT: every axis needs at least 2 samples");
    if (volume.dims.x > 4096 || volume.dims.y > 4096 || volume.dims.z > 4096 ||
        volume.count() >= (int64_t(1) << 31))
        throw Error(ErrorCode::TooLarge, "MT: volume too large for the in-core builder");
    if (options.brick_cells < 0) throw Error(ErrorCode::InvalidArgument, "MT: negative brick size");
    if (!(options.pass_error_cap >= 0))
        throw Error(ErrorCode::InvalidArgument, "MT: the pass error cap must be >= 0 (+inf: none)");
    MtModel m;
    m.field_ = std::move(volume);
    const Volume& vol = m.field_;
    const uint32_t n = uint32_t(vol.count());
    // History node ids are provisional (>= kProvisional) until merged, which needs 2n of room.
    if (options.record_history && uint64_t(2) * n >= mt::kProvisional)
        throw Error(ErrorCode::TooLarge, "MT: history recording is for small volumes");
    if (options.record_history) m.history_.emplace_back();

    // At most one update per grid point: reserving them spares the copy of a doubling.
    m.updates_.reserve(n);
    mt::NodeState nodes;
    nodes.node.resize(n);
    for (uint32_t i = 0; i < n; ++i) nodes.node[i] = i;
    nodes.label.assign(n, 0);
    nodes.err.assign(n, 0.0f);

    const std::array<int64_t, 3> cells{vol.dims.x - 1, vol.dims.y - 1, vol.dims.z - 1};
    const std::vector<mt::PassFaces> passes = mt::plan_brick_passes(cells, options.brick_cells);
    const std::array<double, 2> value_range = vol.range();
    const double range_span = value_range[1] - value_range[0];
    std::vector<mt::BrickMesh> prev;  // the meshes of the last pass, then the tets carried over it
    mt::BrickMesh carry;
    uint64_t mask_bits = 0;
    mt::BrickResult::Stats total_stats, pass_stats;
    const bool stats = std::getenv("TETLOD_MT_STATS") != nullptr;
    tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
    mt::BuildProgress progress(options.progress, passes);
    progress.start();
    for (int pass = 0; pass < int(passes.size()); ++pass) {
        const mt::PassFaces& faces = passes[size_t(pass)];
        std::array<int64_t, 3> count;
        for (int a = 0; a < 3; ++a) count[a] = int64_t(faces[a].size()) - 1;
        const size_t bricks = size_t(count[0] * count[1] * count[2]);
        int64_t largest_brick = 0;
        std::vector<mt::BrickBox> boxes(bricks);
        for (size_t b = 0; b < bricks; ++b) {
            const std::array<int64_t, 3> at{int64_t(b) % count[0], int64_t(b) / count[0] % count[1],
                                            int64_t(b) / (count[0] * count[1])};
            for (int a = 0; a < 3; ++a) {
                boxes[b].lo[a] = faces[a][size_t(at[a])];
                boxes[b].hi[a] = faces[a][size_t(at[a]) + 1];
                largest_brick = std::max(largest_brick, boxes[b].hi[a] - boxes[b].lo[a]);
            }
        }
        // The mesh so far, cut along this pass's bricks; tets crossing a face wait, and
        // their vertices stay frozen, until a pass has a brick that holds them.
        std::vector<mt::BrickMesh> meshes;
        std::vector<std::vector<mt::BrickMesh*>> inputs(bricks);
        if (pass > 0) {
            prev.push_back(std::move(carry));
            mt::distribute_tets(prev, faces, vol.dims, meshes, carry);
            prev.clear();
            if (carry.tets != 0) {
                nodes.pinned.resize(n);
                mt::pin_vertices(carry, nodes.pinned);
            } else {
                nodes.pinned = {};
            }
            for (size_t b = 0; b < bricks; ++b) inputs[b].push_back(&meshes[b]);
        }
        // Every pass but the last stops at an error cap growing with the bricks, so the
        // collapses of the whole volume happen roughly in the order of their errors, as in
        // one greedy decimation: a brick decimated to the end would leave its frozen border
        // fine below coarse interiors, and every coarse LOD would then carry those borders
        // (their nodes get the largest labels, so the splits of the interiors force them).
        MtBuildOptions pass_options = options;
        if (pass + 1 < int(passes.size()))
            pass_options.max_error = std::min(
                options.max_error, pass_error_cap(pass, int(passes.size()), range_span, options.pass_error_cap));
        const auto t0 = std::chrono::steady_clock::now();
        std::atomic<int> in_flight{0}, most_in_flight{0};  // statistics only
        std::vector<mt::BrickResult> results(bricks);
        // Merge in brick order (updates, masks, node ids), each brick as soon as the ones
        // before it are merged: results do not pile up until the pass ends, and the merged
        // updates are not held twice (bucky 128³: 1.66 M updates of 20 B in pass 0).
        std::mutex merging;
        std::vector<uint8_t> finished(bricks, 0);
        size_t merged = 0;
        prev.clear();
        auto merge = [&](mt::BrickResult& r) {
            const uint32_t first = uint32_t(m.updates_.size());
            m.updates_.insert(m.updates_.end(), r.updates.begin(), r.updates.end());
            append_bits(m.mask_bits_, mask_bits, r.mask_bits, r.mask_bit_count);
            mask_bits += r.mask_bit_count;
            pass_stats.add(r.stats);
            if (options.record_history) {
                // The nodes fixed here are free points of a finished brick: no brick
                // still running reads them (bricks of a pass touch disjoint nodes).
                auto fix = [&](uint32_t& id) {
                    if (id >= mt::kProvisional) id = n + first + (id - mt::kProvisional);
                };
                for (const MtUpdate& u : r.updates) fix(nodes.node[u.s]);
                MtHistory& h = m.history_.front();
                for (auto* lists : {&r.history.before, &r.history.after})
                    for (auto& tets : *lists)
                        for (auto& t : tets)
                            for (uint32_t& id : t) fix(id);
                for (auto& tets : r.history.before) h.before.push_back(std::move(tets));
                for (auto& tets : r.history.after) h.after.push_back(std::move(tets));
                for (uint32_t k : r.history.update_of_node) h.update_of_node.push_back(first + k);
            }
            prev.push_back(std::move(r.mesh));
            r = mt::BrickResult{};
        };
        BrickAdmission admission(std::max(kBrickBudgetPerPoint * size_t(n), kBrickBudgetFloor));
        // Fewer bricks than threads (the last pass): the bricks' evaluations use the rest
        // from the start. Otherwise from the moment a brick ends with none left to start:
        // its thread would idle while the others finish theirs (no outer task is left for
        // a thread waiting on a walk to take up).
        std::atomic<bool> spare_threads{bricks < size_t(arena.max_concurrency())};
        // Larger first (by powers of two of their working bytes), so that the pass does
        // not end on one large brick alone. They still merge in brick order (same bytes
        // whatever order they run in), so bricks of about the same size keep that order:
        // a finished brick's result waits for those before it to merge.
        std::vector<size_t> work(bricks), start_order(bricks);
        for (size_t b = 0; b < bricks; ++b) work[b] = mt::brick_working_bytes(boxes[b], inputs[b]), start_order[b] = b;
        std::stable_sort(start_order.begin(), start_order.end(),
                         [&](size_t a, size_t b) { return std::bit_width(work[a]) > std::bit_width(work[b]); });
        std::atomic<size_t> next_start{0};
        arena.execute([&] {
            tbb::parallel_for(size_t(0), bricks, size_t(1), [&](size_t) {
                const size_t b = start_order[next_start++];
                std::optional<BrickAdmission::Ticket> ticket;
                ticket.emplace(admission, work[b]);
                const int now = ++in_flight;
                for (int seen = most_in_flight; now > seen && !most_in_flight.compare_exchange_weak(seen, now);) {
                }
                uint64_t reported = 0;
                mt::BrickProgress within;
                if (options.progress)
                    within = [&](uint64_t collapses, uint64_t candidates) {
                        progress.brick_part(pass, boxes[b], double(collapses) / double(candidates), reported);
                    };
                results[b] = mt::decimate_brick(vol, pass_options, boxes[b], inputs[b], nodes, within,
                                                &spare_threads);
                --in_flight;
                if (next_start.load() >= bricks) spare_threads = true;
                ticket.reset();
                {
                    std::lock_guard<std::mutex> lock(merging);
                    finished[b] = 1;
                    for (; merged < bricks && finished[merged]; ++merged) merge(results[merged]);
                }
                release_free_heap();
                progress.brick_done(pass, boxes[b], reported);
            });
        });
        if (merged != bricks) throw Error(ErrorCode::CorruptData, "mt build: internal error (a brick was not merged)");
        if (stats) {
            size_t handed_tets = carry.tets, handed_bytes = carry.bytes.size();
            for (const mt::BrickMesh& mesh : prev) handed_tets += mesh.tets, handed_bytes += mesh.bytes.size();
            std::fprintf(stderr, "mt build: pass of %zu bricks of up to %lld cells (up to %d at once, %zu tets carried over): %.2f s, %zu collapses so far; mesh handed over: %zu tets in %.1f MB\n",
                         bricks, (long long)largest_brick, most_in_flight.load(), carry.tets,
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                         m.updates_.size(), handed_tets, double(handed_bytes) / 1048576.0);
            print_stats("pass", pass_stats);
        }
        total_stats.add(pass_stats);
        pass_stats = {};
    }
    if (carry.tets != 0 || prev.size() != 1)
        throw Error(ErrorCode::CorruptData, "mt build: internal error (the last pass is not one brick)");
    m.base_ = mt::tets_of(prev.front());
    prev.clear();
    if (options.record_history)
        for (const auto& t : m.base_)
            m.history_.front().base.push_back(
                {nodes.node[t[0]], nodes.node[t[1]], nodes.node[t[2]], nodes.node[t[3]]});
    if (stats) print_stats("build", total_stats);
    m.finalize();
    return m;
}

}  // namespace tetlod
