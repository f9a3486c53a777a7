// Selective refinement on the HT (normative: spec/ht-model.md §H2-§H3; docs/ht.md).
//
// Phase 1 (split set): the diamonds of the violating root tets are split; a
// split diamond's parents are split (a diamond's tets exist only once all its
// parents are), and so is the diamond of every violating child tet of a split
// diamond. The least set closed under these rules is the unique coarsest
// conforming mesh that honours the query; threads build it together, each
// claiming diamonds atomically, in any order. Its vertices are then numbered
// in Morton order, so the mesh does not depend on the number of threads.
// Phase 2 (emit): walk the bisection tree from the 6 roots with Maubach's
// ordered tets; a tet whose diamond is split recurses, any other is output.
//
// Data box B = [0,bx]x[0,by]x[0,bz] inside the cube [0,L]^3: tets outside B are
// never output nor split for their own sake; tets crossing B's far faces always
// violate. Diamonds centred outside B therefore never need an error (all their
// tets cross or lie outside); their split marks live in a small hash set.
//
// One algorithm, two instantiations: over the in-memory model's arrays (a
// split bitset and a vertex index per grid point, the fastest when the grid is
// in memory anyway), and over a sample source (ht_sample_source.hpp) with the
// split set and vertex numbering in a blocked point map sized by the output.
#include <tbb/concurrent_unordered_set.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_for_each.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "tetlod/models/detail/ht_geometry.hpp"
#include "tetlod/models/detail/blocked_point_map.hpp"
#include "tetlod/models/ht/ht_sample_source.hpp"
#include "tet_box.hpp"
#include "../query/lod_query_region.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {
namespace {

using ht::BoxRelation;
using ht::DiamondInfo;
using ht::Pt;
using ht::Tet;

/// A tet waiting in the violation stack: vertices with the spine first.
struct PendingTet {
    Tet v;
    uint8_t level;
};

// The emit walk is cut into subtrees at this level (<= 6 * 2^12 subtrees).
constexpr int kEmitCutLevel = 12;
// Below this many split diamonds the mesh is small: emit on the calling thread.
constexpr uint64_t kParallelEmitMinSplits = 20000;
// Streaming: the walk's subtrees in this many batches (a batch's tets are
// held until handed over), this many emitted at once.
constexpr std::size_t kStreamChunks = 4096;
constexpr std::size_t kStreamChunksInFlight = 16;

uint64_t pack(const Pt& p) {
    return (uint64_t(uint32_t(p[0])) << 42) | (uint64_t(uint32_t(p[1])) << 21) | uint64_t(p[2]);
}

/// A hash of packed points for TBB's concurrent sets, whose buckets are the
/// hash's low bits: std::hash<uint64_t> is the identity there, and every
/// point of the plane z = 2^k (outside the data box of a volume whose z is not
/// 2^k + 1) had the same low bits, one bucket, so lookups walked a chain of
/// all of them (a fifth of a 5 % LOD of bucky 128^3). The MurmurHash3 finaliser.
struct PackedPointHash {
    std::size_t operator()(uint64_t k) const {
        k ^= k >> 33;
        k *= 0xff51afd7ed558ccdull;
        k ^= k >> 33;
        k *= 0xc4ceb9fe1a85ec53ull;
        k ^= k >> 33;
        return std::size_t(k);
    }
};

constexpr uint32_t kNoVertex = 0xFFFFFFFFu;
using VertexIds = std::array<uint32_t, 4>;

// ---- where the data is read: Access (error, value, fork, fill_values) ----

/// The in-memory model's arrays.
class ArrayAccess {
public:
    explicit ArrayAccess(const HtModel& m)
        : err_(m.diamond_errors().data()), field_(&m.field()), X_(m.field().dims.x),
          XY_(m.field().dims.x * m.field().dims.y), unit_error_(m.field_error_bound()) {}
    float error(const Pt& p) const { return err_[index(p)]; }
    float unit_error() const { return unit_error_; }
    void prefetch_error(const Pt& p) const { __builtin_prefetch(&err_[index(p)]); }
    double value(const Pt& p) const { return field_->value(index(p)); }
    const ArrayAccess& fork() const { return *this; }
    static constexpr bool wants_hints() { return false; }
    void prefetch(const Pt*, int) const {}
    void fill_values(const std::vector<Pt>& points, std::vector<double>& values) const {
        values.resize(points.size());
        dispatch_value_type(field_->type, [&](auto tag) {  // one type dispatch for all vertices
            using T = decltype(tag);
            const T* f = field_->as<T>();
            for (std::size_t v = 0; v < points.size(); ++v) values[v] = double(f[index(points[v])]);
        });
    }

private:
    int64_t index(const Pt& p) const { return p[2] * XY_ + p[1] * X_ + p[0]; }
    const float* err_;
    const Volume* field_;
    int64_t X_, XY_;
    float unit_error_;
};

/// A sample source; fork() gives each emit task its own.
class SourceAccess {
public:
    explicit SourceAccess(HtSampleSource& s) : s_(&s) {}
    explicit SourceAccess(std::unique_ptr<HtSampleSource> owned) : s_(owned.get()), owned_(std::move(owned)) {}
    float error(const Pt& p) const { return s_->error(p); }
    float unit_error() const { return s_->field_error_bound(); }
    void prefetch_error(const Pt&) const {}
    double value(const Pt& p) const { return s_->value(p); }
    SourceAccess fork() const { return SourceAccess(s_->fork()); }
    static constexpr bool wants_hints() { return true; }
    void prefetch(const Pt* points, int n) const { s_->prefetch(points, n); }
    void fill_values(const std::vector<Pt>& points, std::vector<double>& values) const {
        values.resize(points.size());
        for (std::size_t v = 0; v < points.size(); ++v) values[v] = s_->value(points[v]);
    }

private:
    HtSampleSource* s_;
    std::shared_ptr<HtSampleSource> owned_;
};

// ---- split marks and vertex ids of points in B: Marks ----

/// Canonical vertex order: Morton (z-order) of the coordinates, so vertex ids
/// depend on the split set only, never on the order in which threads found it.
/// The comparison of the most significant differing bit, without keys.
inline bool morton_less(const Pt& a, const Pt& b) {
    int axis = 2;
    uint32_t top = 0;
    for (int d = 2; d >= 0; --d) {
        const uint32_t x = uint32_t(a[std::size_t(d)]) ^ uint32_t(b[std::size_t(d)]);
        if (top < x && top < (top ^ x)) {
            top = x;
            axis = d;
        }
    }
    return a[std::size_t(axis)] < b[std::size_t(axis)];
}

/// The points `visit(u, f)` passes to f over units u = 0 .. units - 1, after
/// `first`, in one vector of exactly their size: counted per stretch of
/// units, then written in place (no per-thread copies to concatenate).
template <class Visit>
std::vector<Pt> gather_vertices(const std::vector<Pt>& first, std::size_t units, Visit visit) {
    constexpr std::size_t kStretch = 1024;
    const std::size_t stretches = (units + kStretch - 1) / kStretch;
    std::vector<std::size_t> at(stretches + 1, 0);
    tbb::parallel_for(std::size_t(0), stretches, [&](std::size_t k) {
        std::size_t n = 0;
        for (std::size_t u = k * kStretch; u < std::min(units, (k + 1) * kStretch); ++u) visit(u, [&](const Pt&) { ++n; });
        at[k + 1] = n;
    });
    at[0] = first.size();
    for (std::size_t k = 0; k < stretches; ++k) at[k + 1] += at[k];
    std::vector<Pt> all(at[stretches]);
    std::copy(first.begin(), first.end(), all.begin());
    tbb::parallel_for(std::size_t(0), stretches, [&](std::size_t k) {
        std::size_t i = at[k];
        for (std::size_t u = k * kStretch; u < std::min(units, (k + 1) * kStretch); ++u)
            visit(u, [&](const Pt& p) { all[i++] = p; });
    });
    return all;
}

/// A bit and a vertex index per grid point, in untouched zero pages until used.
/// Splits may be claimed from several threads at once; ids are set after.
class DenseMarks {
public:
    explicit DenseMarks(const Dims& d) : X_(d.x), XY_(d.x * d.y) {
        const int64_t n = d.count();
        split_.resize(static_cast<std::size_t>((n + 63) / 64));
        ids_.reset(new uint32_t[static_cast<std::size_t>(n)]);
    }
    bool split(const Pt& c) const {
        const int64_t i = index(c);
        return (word(i >> 6).load(std::memory_order_relaxed) >> (i & 63)) & 1;
    }
    /// Is c split; if so, its vertex id in `id` (after number_vertices).
    bool split_id(const Pt& c, uint32_t& id) const {
        if (!split(c)) return false;
        id = ids_[index(c)];
        return true;
    }
    /// Marks c split: true if this call did (of racing threads, one does).
    bool claim(const Pt& c) {
        const int64_t i = index(c);
        const uint64_t bit = uint64_t{1} << (i & 63);
        return !(word(i >> 6).fetch_or(bit, std::memory_order_relaxed) & bit);
    }
    void add_corner(const Pt& c) { corners_.push_back(c); }
    uint32_t id(const Pt& p) const { return ids_[index(p)]; }

    /// Every vertex: split centres and corners, in no particular order.
    std::vector<Pt> vertices() const {
        return gather_vertices(corners_, split_.size(), [&](std::size_t w, auto&& f) {
            for (uint64_t bits = split_[w]; bits; bits &= bits - 1) {
                const int64_t i = int64_t(w) * 64 + std::countr_zero(bits);
                f(Pt{int32_t(i % X_), int32_t(i % XY_ / X_), int32_t(i / XY_)});
            }
        });
    }
    void set_id(const Pt& p, uint32_t id) { ids_[index(p)] = id; }

private:
    int64_t index(const Pt& p) const { return p[2] * XY_ + p[1] * X_ + p[0]; }
    std::atomic_ref<uint64_t> word(int64_t w) const {
        return std::atomic_ref<uint64_t>(const_cast<uint64_t&>(split_[std::size_t(w)]));
    }
    int64_t X_, XY_;
    ZeroedVector<uint64_t> split_;
    std::unique_ptr<uint32_t[]> ids_;  // valid only at vertices (split centres, corners)
    std::vector<Pt> corners_;
};

/// One map entry per vertex: id << 1 | split (before numbering: id 0).
class SparseMarks {
public:
    explicit SparseMarks(const Dims& d) : map_(std::max({d.x, d.y, d.z}) - 1) {}
    bool split(const Pt& c) const {
        uint32_t v;
        return map_.find(c, v) && (v & 1);
    }
    bool split_id(const Pt& c, uint32_t& id) const {
        uint32_t v;
        if (!map_.find(c, v) || !(v & 1)) return false;
        id = v >> 1;
        return true;
    }
    bool claim(const Pt& c) { return map_.set_bit0(c); }
    void add_corner(const Pt& c) { map_.put(c, 0); }
    uint32_t id(const Pt& p) const {
        uint32_t v;
        return map_.find(p, v) ? v >> 1 : kNoVertex;
    }
    std::vector<Pt> vertices() const {
        return gather_vertices({}, map_.block_count(), [&](std::size_t b, auto&& f) {
            map_.for_each_in_block(uint32_t(b), [&](const Pt& p, uint32_t) { f(p); });
        });
    }
    void set_id(const Pt& p, uint32_t id) {
        uint32_t v = 0;
        map_.find(p, v);
        map_.put(p, id << 1 | (v & 1));
    }

private:
    detail::BlockedPointMap map_;
};

template <class Access, class Marks>
class Refiner {
public:
    /// `labels`: geometry, field name and value type of the mesh (its arrays are ignored).
    Refiner(const HtDomain& dom, Access access, const LodQuery& q, const TetMesh& labels = {})
        : dom_(dom),
          acc_(std::move(access)),
          q_(q),
          bounds_(detail::query_bounds(q)),
          marks_(dom.dims()) {
        eps_in_ = bounds_.in;
        eps_out_ = bounds_.out;
        has_region_ = bounds_.region;
        eps_min_ = bounds_.min();
        eps_max_ = bounds_.max();
        mesh_.geometry = labels.geometry;
        mesh_.field_name = labels.field_name;
        mesh_.value_type = labels.value_type;
    }

    /// The whole mesh.
    TetMesh run(HtExtractStats* stats) {
        const auto t0 = std::chrono::steady_clock::now();
        ht::MTet roots[6];
        refine(roots);
        const auto t1 = std::chrono::steady_clock::now();
        emit_all(roots);
        acc_.fill_values(mesh_.points, mesh_.values);
        report(stats, t0, t1);
        return std::move(mesh_);
    }

    /// The mesh in parts: vertices, then tets in batches as they are emitted
    /// (a counting walk first, for the count the sink needs up front).
    void run_to(TetMeshSink& sink, HtExtractStats* stats) { run_share(sink, stats, HtEmitShare{}); }

    /// Share `share.index` of `share.count` of run_to's output: the same
    /// split set and vertex numbering (phase 1 is whole: it alone decides the
    /// mesh, so every share numbers vertices alike), but only a run of the
    /// walk's subtrees emitted. The runs are cut at equal fractions of the
    /// total tet count, which every share computes alike, so the runs in share
    /// order are run_to's tets in its order. sink.begin gets the whole count.
    void run_share(TetMeshSink& sink, HtExtractStats* stats, const HtEmitShare& share) {
        const auto t0 = std::chrono::steady_clock::now();
        ht::MTet roots[6];
        refine(roots);
        const auto t1 = std::chrono::steady_clock::now();
        if (share.vertex_values) acc_.fill_values(mesh_.points, mesh_.values);
        const std::vector<EmitItem> items = emit_items(roots);
        std::vector<uint64_t> counts(items.size());
        tbb::parallel_for(std::size_t(0), items.size(),
                          [&](std::size_t i) { counts[i] = count(items[i].t, items[i].inside); });
        uint64_t total = 0;
        for (uint64_t c : counts) total += c;
        sink.begin(mesh_, total);
        mesh_.points = {};
        mesh_.values = {};
        // This share's items: those whose first tet's index lies in
        // [total * index / count, total * (index + 1) / count).
        std::size_t first = 0, last = items.size();
        if (share.count > 1) {
            const auto at = [&](int k) { return uint64_t((unsigned __int128)total * uint64_t(k) / uint64_t(share.count)); };
            const uint64_t lo = at(share.index), hi = at(share.index + 1);
            uint64_t before = 0;
            first = last = items.size();
            for (std::size_t i = 0; i < items.size(); ++i) {
                if (first == items.size() && before >= lo && counts[i] > 0) first = i;
                if (before >= hi) {
                    last = i;
                    break;
                }
                before += counts[i];
            }
            if (first > last) first = last;
        }
        const std::size_t span = last - first;
        // Batches of subtrees, emitted in parallel, handed over in order.
        const std::size_t chunks = std::min<std::size_t>(span, kStreamChunks);
        for (std::size_t g = 0; g < chunks; g += kStreamChunksInFlight) {
            const std::size_t n = std::min(kStreamChunksInFlight, chunks - g);
            std::vector<EmitBuffer> out(n);
            auto run_chunk = [&](std::size_t j) {
                auto acc = acc_.fork();
                const std::size_t k = g + j;
                const std::size_t b = first + span * k / chunks, e = first + span * (k + 1) / chunks;
                for (std::size_t i = b; i < e; ++i)
                    emit(acc, items[i].t, items[i].ids, items[i].inside, items[i].positive, out[j]);
            };
            if (split_count_ > kParallelEmitMinSplits)
                tbb::parallel_for(std::size_t(0), n, run_chunk);
            else
                for (std::size_t j = 0; j < n; ++j) run_chunk(j);
            for (auto& o : out) {
                sink.add(o.tets, o.level, o.error);
                visited_ += o.visited;
                max_error_ = std::max(max_error_, o.max_error);
                o = EmitBuffer{};
            }
        }
        visited_ += span;
        sink.finish();
        report(stats, t0, t1);
    }

private:
    /// Phase 1: the split set, then the vertices numbered in canonical order.
    ///
    /// The split set is the least set that holds the diamonds of the violating
    /// root tets and is closed under two rules: a split diamond's parents are
    /// split, and so is the diamond of every violating child tet of a split
    /// diamond. Both rules look at one diamond and the data only, so threads
    /// may apply them in any order: each claims a diamond (one thread wins),
    /// then queues its unsplit parents and violating children. The result is
    /// the same set for any number of threads; numbering its vertices in
    /// Morton order afterwards makes the whole mesh independent of them.
    void refine(ht::MTet roots[6]) {
        // Cube corners inside B are vertices of every mesh.
        for (int m = 0; m < 8; ++m) {
            Pt c{(m & 1) ? dom_.L : 0, (m & 2) ? dom_.L : 0, (m & 4) ? dom_.L : 0};
            if (in_box(c)) marks_.add_corner(c);
        }
        ht::maubach_roots(dom_.L, roots);
        std::vector<Pt> initial;
        for (int r = 0; r < 6; ++r) {
            PendingTet p{spine_first(roots[r].v, roots[r].tag), 0};
            if (!ok(acc_, p)) initial.push_back(ht::midpoint(p.v[0], p.v[1]));
        }
        tbb::enumerable_thread_specific<Worker> workers([this] { return Worker{acc_.fork(), {}, 0}; });
        std::vector<std::vector<Pt>> batches;
        {
            Worker first{acc_.fork(), {}, 0};
            for (const Pt& c : initial) queue(first, c);
            for (const Pt& c : first.stack) batches.push_back({c});
        }
        tbb::parallel_for_each(batches.begin(), batches.end(), [&](const std::vector<Pt>& batch,
                                                                   tbb::feeder<std::vector<Pt>>& feeder) {
            Worker& w = workers.local();
            w.stack.insert(w.stack.end(), batch.begin(), batch.end());  // hinted when first queued
            while (!w.stack.empty()) {
                step(w);
                // A deep stack: hand its oldest (coarsest) half to an idle
                // thread, as one task (a task per diamond would cost more
                // than the diamond).
                if (w.stack.size() >= kShareAbove) {
                    const auto half = std::ptrdiff_t(w.stack.size() / 2);
                    feeder.add(std::vector<Pt>(w.stack.begin(), w.stack.begin() + half));
                    w.stack.erase(w.stack.begin(), w.stack.begin() + half);
                }
            }
        });
        for (const Worker& w : workers) split_count_ += w.splits;
        number_vertices();
    }

    /// Vertex ids in Morton order of the vertices.
    void number_vertices() {
        std::vector<Pt> points = marks_.vertices();
        if (points.size() >= 0x7FFFFFFFu)
            throw Error(ErrorCode::TooLarge, "the mesh would have more than 2^31 vertices");
        tbb::parallel_sort(points.begin(), points.end(), morton_less);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& r) {
            for (std::size_t i = r.begin(); i < r.end(); ++i) marks_.set_id(points[i], uint32_t(i));
        });
        mesh_.points = std::move(points);
    }

    void report(HtExtractStats* stats, std::chrono::steady_clock::time_point t0,
                std::chrono::steady_clock::time_point t1) const {
        const auto t2 = std::chrono::steady_clock::now();
        if (!stats) return;
        stats->refine_seconds = std::chrono::duration<double>(t1 - t0).count();
        stats->emit_seconds = std::chrono::duration<double>(t2 - t1).count();
        stats->max_error = max_error_;
        stats->split_diamonds = split_count_;
        stats->visited_tets = visited_;
    }

    /// Tets the emit walk outputs under t.
    uint64_t count(const ht::MTet& t, bool inside) const {
        bool refine = false;
        if (!inside) {
            const BoxRelation rel = ht::classify_against_data_box(t.v, dom_.box_max);
            if (rel == BoxRelation::Outside) return 0;
            refine = rel == BoxRelation::Crossing;
            inside = !refine;
        }
        if (!refine && (t.level >= dom_.max_level() || !marks_.split(ht::maubach_centre(t)))) return 1;
        ht::MTet c1, c2;
        ht::maubach_bisect(t, c1, c2);
        return count(c1, inside) + count(c2, inside);
    }

    static Tet spine_first(const Tet& v, int tag) {
        Tet t{v[0], v[tag], {}, {}};
        int n = 2;
        for (int i = 1; i < 4; ++i)
            if (i != tag) t[n++] = v[i];
        return t;
    }

    bool in_box(const Pt& p) const { return dom_.in_box(p[0], p[1], p[2]); }

    bool is_split(const Pt& c) const {
        if (in_box(c)) return marks_.split(c);
        return outside_split_.count(pack(c)) != 0;
    }

    /// Marks c split: true if this thread did.
    bool claim(const Pt& c) {
        if (in_box(c)) return marks_.claim(c);
        return outside_split_.insert(pack(c)).second;
    }

    /// Does the tet satisfy its bound (or need no split for its own sake)?
    bool ok(Access& acc, const PendingTet& t) const {
        switch (ht::classify_against_data_box(t.v, dom_.box_max)) {
            case BoxRelation::Outside: return true;
            case BoxRelation::Crossing: return false;
            case BoxRelation::Inside: break;
        }
        if (t.level >= dom_.max_level()) return true;
        const double err = acc.error(ht::midpoint(t.v[0], t.v[1]));
        if (err <= std::min(eps_in_, eps_out_)) return true;  // no region test needed
        return err <= detail::query_bound(q_, bounds_, t.v, [&](int i) { return acc.value(t.v[i]); }, err);
    }

    /// One thread's share of phase 1: its own sample access and stack.
    struct Worker {
        Access acc;
        std::vector<Pt> stack;
        uint64_t splits = 0;
    };
    // A worker's stack beyond this many diamonds feeds other threads.
    static constexpr std::size_t kShareAbove = 1024;

    /// Queues a diamond for splitting. Splitting it reads its children's
    /// errors: a source that decodes in pieces is told now, so it can decode
    /// them in the background while the refinement works through the stack.
    /// Every diamond queued is split (if not already, by whoever split it,
    /// who read the same children), so what is fetched this way is read (but
    /// for children whose tets cross the data box's far faces, which need no
    /// error): decoding ahead changes the time, not the chunks a query reads.
    void queue(Worker& w, const Pt& c) const {
        w.stack.push_back(c);
        if constexpr (Access::wants_hints()) {
            const DiamondInfo d = ht::classify_centre(c, dom_.k);
            if (d.level + 1 >= dom_.max_level()) return;
            Pt ch[8];
            const int n = ht::diamond_children(c, d, dom_.L, ch);
            int kept = 0;
            for (int i = 0; i < n; ++i)
                if (in_box(ch[i])) ch[kept++] = ch[i];
            w.acc.prefetch(ch, kept);
        }
    }

    /// Works on the diamond atop w's stack: its unsplit parents go first (on
    /// top of it), as parents left for later would be queued again by each of
    /// its descendants; once they are split, the diamond is claimed and its
    /// violating children are queued. Another thread may claim any of these
    /// first; then it applies the rules instead.
    void step(Worker& w) {
        const Pt c = w.stack.back();
        if (is_split(c)) {
            w.stack.pop_back();
            return;
        }
        const DiamondInfo d = ht::classify_centre(c, dom_.k);
        Pt parents[4];
        const int np = ht::diamond_parents(c, d, dom_.L, parents);
        bool ready = true;
        for (int i = 0; i < np; ++i)
            if (!is_split(parents[i])) {
                w.stack.push_back(parents[i]);
                ready = false;
            }
        if (!ready) return;
        w.stack.pop_back();
        if (!claim(c)) return;
        ++w.splits;
        // Interior diamond: its children's errors are read next; start those
        // (scattered) loads before the bookkeeping.
        const auto& m = dom_.box_max;
        const bool interior = c[0] - d.h >= 0 && c[1] - d.h >= 0 && c[2] - d.h >= 0 && c[0] + d.h <= m[0] &&
                              c[1] + d.h <= m[1] && c[2] + d.h <= m[2];
        Pt ch[8];
        int nch = 0;
        if (interior && d.level + 1 < dom_.max_level()) {
            nch = ht::diamond_children(c, d, dom_.L, ch);
            for (int i = 0; i < nch; ++i) w.acc.prefetch_error(ch[i]);
        }
        if (!interior || !queue_children_fast(w, ch, nch)) queue_children(w, c, d);
    }

    /// Interior diamonds (all tets, hence all children tets, inside B): the
    /// children tets of the diamond belong to its child diamonds, so under a
    /// bound that does not depend on the tet, a child diamond must split exactly
    /// when its error exceeds the bound. `ch` holds the child diamonds (none when
    /// they are unit tets). Returns false to ask for the per-tet path: a child
    /// whose verdict depends on the region test.
    bool queue_children_fast(Worker& w, const Pt ch[8], int n) const {
        // n == 0 also when the children are unit tets (always ok)
        int pushed = 0;
        Pt todo[8];
        for (int i = 0; i < n; ++i) {
            const float e = w.acc.error(ch[i]);
            if (e <= eps_min_) continue;
            if (has_region_ && e <= eps_max_) return false;
            todo[pushed++] = ch[i];
        }
        for (int i = 0; i < pushed; ++i)
            if (!is_split(todo[i])) queue(w, todo[i]);
        return true;
    }

    void queue_children(Worker& w, const Pt& c, const DiamondInfo& d) const {
        Tet tets[8];
        const int nt = ht::diamond_tets(c, d, dom_.L, tets);
        // Up to 16 children tets name at most 8 child diamonds: queue each once.
        Pt todo[16];
        int pushed = 0;
        auto push = [&](const Pt& m) {
            for (int j = 0; j < pushed; ++j)
                if (todo[j] == m) return;
            todo[pushed++] = m;
        };
        for (int i = 0; i < nt; ++i) {
            if (ht::classify_against_data_box(tets[i], dom_.box_max) == BoxRelation::Outside)
                continue;
            const Tet& t = tets[i];
            // children: replace one spine end by the centre; respine each
            for (int side = 0; side < 2; ++side) {
                PendingTet ch;
                ch.level = uint8_t(d.level + 1);
                Tet v{side == 0 ? t[0] : t[1], c, t[2], t[3]};
                ch.v = respine(v);
                if (!ok(w.acc, ch)) push(ht::midpoint(ch.v[0], ch.v[1]));
            }
        }
        for (int j = 0; j < pushed; ++j)
            if (!is_split(todo[j])) queue(w, todo[j]);
    }

    /// Puts the longest edge first (it is unique in the HT).
    static Tet respine(const Tet& v) {
        static constexpr int kE[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                         {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
        int best = 0;
        int64_t bl = -1;
        for (int e = 0; e < 6; ++e) {
            const int64_t l = ht::dist2(v[kE[e][0]], v[kE[e][1]]);
            if (l > bl) bl = l, best = e;
        }
        return Tet{v[kE[best][0]], v[kE[best][1]], v[kE[best][2]], v[kE[best][3]]};
    }

    /// Output of one stretch of the bisection tree.
    struct EmitBuffer {
        std::vector<std::array<uint32_t, 4>> tets;
        std::vector<uint8_t> level;
        std::vector<float> error;
        uint64_t visited = 0;
        double max_error = 0;
    };
    /// A subtree root (or a leaf) of the tree walk, in depth-first order, with
    /// its vertex ids (kNoVertex outside B).
    struct EmitItem {
        ht::MTet t;
        VertexIds ids;
        bool inside, positive;
    };

    /// Vertex id of the centre of a split tet (kNoVertex outside B).
    uint32_t centre_id(const Pt& c) const { return in_box(c) ? marks_.id(c) : kNoVertex; }

    /// Maubach's children's vertex ids (see ht::maubach_bisect).
    static void bisect_ids(int tag, const VertexIds& ids, uint32_t centre, VertexIds& c1, VertexIds& c2) {
        c1 = ids;
        c1[tag] = centre;
        switch (tag) {
            case 3: c2 = {ids[1], ids[2], ids[3], centre}; break;
            case 2: c2 = {ids[1], ids[2], centre, ids[3]}; break;
            default: c2 = {ids[1], centre, ids[2], ids[3]}; break;
        }
    }

    /// Phase 2. The walk is cut at a fixed depth into subtrees, emitted in
    /// parallel into per-chunk buffers and concatenated in depth-first order, so
    /// the mesh is the same whatever the number of threads.
    std::vector<EmitItem> emit_items(const ht::MTet roots[6]) const {
        std::vector<EmitItem> items;
        const int cut = std::min(dom_.max_level(), kEmitCutLevel);
        for (int r = 0; r < 6; ++r) {
            VertexIds ids;
            for (int i = 0; i < 4; ++i) ids[i] = in_box(roots[r].v[i]) ? marks_.id(roots[r].v[i]) : kNoVertex;
            collect(roots[r], ids, false,
                    ht::orient(roots[r].v[0], roots[r].v[1], roots[r].v[2], roots[r].v[3]) > 0, cut, items);
        }
        return items;
    }

    void emit_all(const ht::MTet roots[6]) {
        const std::vector<EmitItem> items = emit_items(roots);
        const std::size_t chunks = std::min<std::size_t>(items.size(), 256);
        std::vector<EmitBuffer> out(std::max<std::size_t>(chunks, 1));
        auto run_chunk = [&](std::size_t k) {
            auto acc = acc_.fork();
            const std::size_t b = items.size() * k / chunks, e = items.size() * (k + 1) / chunks;
            for (std::size_t i = b; i < e; ++i)
                emit(acc, items[i].t, items[i].ids, items[i].inside, items[i].positive, out[k]);
        };
        if (chunks > 1 && split_count_ > kParallelEmitMinSplits)
            tbb::parallel_for(std::size_t(0), chunks, run_chunk);
        else
            for (std::size_t k = 0; k < chunks; ++k) run_chunk(k);
        std::size_t total = 0;
        for (const auto& o : out) total += o.tets.size();
        mesh_.tets.reserve(total);
        mesh_.level.reserve(total);
        mesh_.error.reserve(total);
        for (auto& o : out) {
            mesh_.tets.insert(mesh_.tets.end(), o.tets.begin(), o.tets.end());
            mesh_.level.insert(mesh_.level.end(), o.level.begin(), o.level.end());
            mesh_.error.insert(mesh_.error.end(), o.error.begin(), o.error.end());
            visited_ += o.visited;
            max_error_ = std::max(max_error_, o.max_error);
            o = EmitBuffer{};  // release as we go
        }
        visited_ += items.size();
    }

    /// Walks down to the cut level, recording subtree roots and leaves above it.
    void collect(const ht::MTet& t, const VertexIds& ids, bool inside, bool positive, int cut,
                 std::vector<EmitItem>& items) const {
        if (t.level >= cut) {
            items.push_back({t, ids, inside, positive});
            return;
        }
        bool refine = false;
        if (!inside) {
            const BoxRelation rel = ht::classify_against_data_box(t.v, dom_.box_max);
            if (rel == BoxRelation::Outside) return;
            refine = rel == BoxRelation::Crossing;
            inside = !refine;
        }
        const Pt centre = ht::maubach_centre(t);
        uint32_t cid = kNoVertex;
        if (refine)
            cid = centre_id(centre);
        else
            refine = marks_.split_id(centre, cid);
        if (!refine) {
            items.push_back({t, ids, inside, positive});  // a leaf: emit() outputs it
            return;
        }
        ht::MTet c1, c2;
        VertexIds i1, i2;
        ht::maubach_bisect(t, c1, c2);
        bisect_ids(t.tag, ids, cid, i1, i2);
        collect(c1, i1, inside, positive, cut, items);
        collect(c2, i2, inside, t.tag == 2 ? positive : !positive, cut, items);
    }

    /// `inside`: the tet is known to lie inside B (then so do its descendants).
    /// `positive`: its vertex order is positively oriented. Maubach's children
    /// keep the parent's orientation (first child) or flip it when the tag is 3
    /// or 1 (second child), so no determinant is needed per tet.
    template <class A>
    void emit(A& acc, const ht::MTet& t, const VertexIds& ids, bool inside, bool positive, EmitBuffer& out) const {
        ++out.visited;
        bool refine = false;
        if (!inside) {
            const BoxRelation rel = ht::classify_against_data_box(t.v, dom_.box_max);
            if (rel == BoxRelation::Outside) return;
            refine = rel == BoxRelation::Crossing;
            inside = !refine;
        }
        uint32_t cid = kNoVertex;
        if (t.level < dom_.max_level()) {
            const Pt centre = ht::maubach_centre(t);
            if (refine)
                cid = centre_id(centre);
            else if (!marks_.split_id(centre, cid)) {
                output(t, ids, positive, acc.error(centre), out);
                return;
            }
        } else if (!refine) {
            // Unit tets: their grid points are their vertices, so no error but the
            // field's own against the original (a lossy container's E, else 0).
            output(t, ids, positive, acc.unit_error(), out);
            return;
        }
        ht::MTet c1, c2;
        VertexIds i1, i2;
        ht::maubach_bisect(t, c1, c2);
        bisect_ids(t.tag, ids, cid, i1, i2);
        emit(acc, c1, i1, inside, positive, out);
        emit(acc, c2, i2, inside, t.tag == 2 ? positive : !positive, out);
    }

    void output(const ht::MTet& t, VertexIds ids, bool positive, float err, EmitBuffer& out) const {
        if (!positive) std::swap(ids[2], ids[3]);
        out.tets.push_back(ids);
        out.level.push_back(t.level);
        out.error.push_back(err);
        out.max_error = std::max(out.max_error, double(err));
    }

    const HtDomain& dom_;
    Access acc_;
    const LodQuery& q_;
    const detail::QueryBounds bounds_;  // after q_: initialised from it
    double eps_in_ = 0, eps_out_ = 0, eps_min_ = 0, eps_max_ = 0;
    bool has_region_ = false;

    Marks marks_;
    tbb::concurrent_unordered_set<uint64_t, PackedPointHash> outside_split_;
    TetMesh mesh_;
    double max_error_ = 0;
    uint64_t split_count_ = 0, visited_ = 0;
};

}  // namespace

namespace {
void label(TetMesh& m, const Volume& f) {
    m.geometry.spacing = f.spacing;
    m.geometry.origin = f.origin;
    m.field_name = f.field_name;
    m.value_type = f.type;
}
}  // namespace

TetMesh HtModel::extract(const LodQuery& query, HtExtractStats* stats) const {
    detail::check_query(query);
    Refiner<ArrayAccess, DenseMarks> r(domain_, ArrayAccess(*this), query);
    TetMesh mesh = r.run(stats);
    label(mesh, *field_);
    return mesh;
}

void HtModel::extract_to(const LodQuery& query, TetMeshSink& sink, HtExtractStats* stats) const {
    detail::check_query(query);
    TetMesh labels;
    label(labels, *field_);
    Refiner<ArrayAccess, DenseMarks> r(domain_, ArrayAccess(*this), query, labels);
    r.run_to(sink, stats);
}

TetMesh refine_ht(const HtDomain& domain, HtSampleSource& source, const LodQuery& query, HtExtractStats* stats) {
    detail::check_query(query);
    Refiner<SourceAccess, SparseMarks> r(domain, SourceAccess(source), query);
    return r.run(stats);
}

void refine_ht_to(const HtDomain& domain, HtSampleSource& source, const LodQuery& query, const TetMesh& labels,
                  TetMeshSink& sink, HtExtractStats* stats, const HtEmitShare& share) {
    detail::check_query(query);
    if (share.count < 1 || share.index < 0 || share.index >= share.count)
        throw Error(ErrorCode::InvalidArgument, "refine_ht_to: share " + std::to_string(share.index) + " of " +
                                                    std::to_string(share.count));
    Refiner<SourceAccess, SparseMarks> r(domain, SourceAccess(source), query, labels);
    r.run_share(sink, stats, share);
}

}  // namespace tetlod
