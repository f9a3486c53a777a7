// MT brick decimator: bottom-up decimation of the 5-tets-per-cell reference mesh
// (or of the child bricks' meshes) inside one brick by half-edge collapses
// (docs/mt.md §2; bricks: mt_decimate.hpp). Legality: box-feature rule,
// strictly positive orientation of every new tet (exact int64), link condition
// with a ghost vertex for the boundary (Dey, Edelsbrunner, Guha, Nekhayev,
// "Topology preserving edge contraction", 1999). Error: every removed grid point is
// kept in the list of one tet containing it; the closed error of each tet and of
// each of its faces is maintained exactly, so an update's error bounds |f - L|
// at every grid point of every tet of its star (docs/mt.md §2).
//
// Order: a heap of one live entry per vertex keyed by (cost, shape ratio, id),
// re-evaluated lazily when its star changed (docs/mt.md §2, "Order"): deterministic.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <numeric>
#include <functional>
#include <queue>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "mt_decimate.hpp"
#include "tetlod/models/detail/mt_geometry.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/huge_page_allocator.hpp"

namespace tetlod::mt {

namespace {
constexpr uint32_t kOmega = 0xFFFFFFFEu;  // ghost vertex (sorts after every grid index)

struct Entry {
    double cost;
    double quality;
    uint32_t w, s, seq, stamp;
    bool dirty;
    bool partial;  // cost is a lower bound: re-evaluate when popped
    // std::priority_queue pops the largest: invert for a min-heap on (cost, quality, w, seq).
    bool operator<(const Entry& o) const {
        if (cost != o.cost) return cost > o.cost;
        if (quality != o.quality) return quality > o.quality;
        if (w != o.w) return w > o.w;
        return seq > o.seq;
    }
};

struct Candidate {
    bool ok = false;
    bool partial = false;  // every target costs more than the cutoff; cost is a lower bound
    double cost = 0, quality = 0;
    uint32_t s = kNil;
    // With neither ok nor partial: the same answer (no target) comes for every cutoff of
    // at least this, as long as the star does not change; +inf when it depended on the
    // link condition, which reads the targets' stars too.
    double none_from = std::numeric_limits<double>::infinity();
    bool link_free = true;  // no target was refused by the link condition
};
}  // namespace

namespace {

// Point ids: the vertices of the brick's input mesh come first, in increasing
// whole-grid order, so every order on vertex ids (heap ties, the canonical star order,
// link keys) is the same as the whole grid's; then the removed points that the input's
// tets own, in the order read (their ids are never compared). Only vertices have
// per-vertex state, and nothing is sized by the brick's box but a bit per box point:
// in the last passes most grid points are long removed (docs/mt.md §2, "Memory").
struct BrickDecimator {
    const Volume& vol;
    const MtBuildOptions& opt;
    const BrickBox& box;
    mt::Grid grid;   // the box
    mt::Grid whole;  // the volume
    Pt origin;       // whole-grid coordinates of the box's first point
    uint32_t box_points;
    uint32_t vertices = 0;  // ids below this are the input mesh's vertices
    bool int_data;
    bool small_int;  // |values| < 2^20: numerators fit in int64
    // How a point record holds its sample: 32 bits are enough for every type but f64,
    // whose samples are read from the volume instead.
    enum class ValueSlot : uint8_t { Signed32, Unsigned32, Float32, InVolume } slot = ValueSlot::Signed32;
    // What the evaluation reads about a point, in 12 bytes: walking a star's points
    // costs one miss per point instead of one per array, and a tet's owned points are
    // one block of records (TetRec::head, owned), walked in address order.
    struct PointRec {
        std::array<uint16_t, 3> at{0, 0, 0};  // box-local coordinates (MtModel::build allows 4096 per axis)
        uint8_t planes = 0;  // planes of the volume's box the point lies on
        uint8_t frozen : 1 = 0;     // on a face of the brick inside the volume, or pinned
        uint8_t alive : 1 = 0;      // a vertex of the brick's mesh (not removed)
        uint8_t collected : 1 = 0;  // set only while evaluate collects a star's neighbours
        uint8_t in_link : 1 = 0;    // set only while link_ok holds Lk(w): a vertex of it
        uint8_t no_target : 1 = 0;  // a vertex whose evaluation found no target (no_target_from)
        uint8_t same_best : 1 = 0;  // a vertex whose exact live entry is what an evaluation finds (run's loop)
        uint32_t value = 0;  // the sample's bits (see ValueSlot)
    };
    static_assert(sizeof(PointRec) == 12);
    // Vertices first (ids below `vertices`, never moved), then the removed points as
    // copies, one block per tet that owns some, in the tet's list order. A collapse
    // writes its new tets' blocks at the end and leaves the old ones as garbage, which
    // compact_owned() squeezes out once it outweighs the live blocks. Until session 28
    // the lists were linked through the records: gathering a star's points was then a
    // chain of dependent misses, 30 % of the last pass (one brick, one thread).
    HugePageVector<PointRec> point;
    size_t owned_live = 0, owned_garbage = 0;  // records in live blocks, in dead ones
    // The vertices of the input among the box's points (raster order), and the count of
    // them before each 64-bit word: a box point's vertex id in O(1).
    std::vector<uint64_t> vertex_bits;
    std::vector<uint32_t> vertices_before;

    // Tets: one cache line each, so that reading a star's tets costs one miss per tet.
    struct alignas(64) TetRec {
        std::array<uint32_t, 4> v{};                         // vertices, positively oriented
        std::array<uint32_t, 4> prev{kNil, kNil, kNil, kNil};  // corner chains: kNil at a chain's head
        std::array<float, 4> ferr{0, 0, 0, 0};               // closed error of the face opposite each corner
        float err = 0;                                       // closed error
        uint32_t head = kNil;                                // first record of its owned points' block
        uint32_t owned = 0;                                  // their count
        // Removed by a collapse (in the record's padding: a list of the removed tets
        // took up to 8 B per tet with its doubling, the brick's largest array after
        // the tets and their back links).
        bool dead = false;
    };
    static_assert(sizeof(TetRec) == 64);
    HugePageVector<TetRec> tets;
    // Per corner (4 * tet + slot): the next corner of its vertex's chain. Apart from the
    // tets (16 B a tet, not 64), so a star walk's dependent loads hit a small array and
    // the loads of the tets themselves overlap (they were 12-16 % of a build, in the walk).
    HugePageVector<uint32_t> next_corner;

    // Per vertex (sized by the vertices, not the box).
    std::vector<uint32_t> vhead;  // first corner
    std::vector<uint32_t> stamp, live_seq;
    // With point[v].no_target: v's last evaluation found no target, and will find none
    // again for any cutoff of at least this (Candidate::none_from, rounded up), until
    // v's star changes (commit clears the flag of every vertex of the changed tets).
    std::vector<float> no_target_from;

    const std::vector<BrickMesh*>& input;
    NodeState& nodes;
    BrickResult& out;
    uint32_t seq_counter = 0;
    std::priority_queue<Entry> heap;
    /// Evaluations walk their points on several threads (walk_points_in_parallel) when
    /// they have at least kParallelPoints, while this reads true: from the start of a
    /// pass of fewer bricks than threads (the last pass: one brick), and in any pass
    /// once every brick has started, when finished threads would idle.
    const std::atomic<bool>* spare_threads = nullptr;
    bool parallel_points() const { return spare_threads && spare_threads->load(std::memory_order_relaxed); }
    static constexpr size_t kParallelPoints = 128, kPointGrain = 64;
    /// A target's walk over the star's points runs its first kSequentialPoints on the
    /// evaluating thread, and only the rest, if the walk gets that far, on the arena's
    /// threads: most walks end at one of their first points (a cost over the cutoff or
    /// a point outside the new tets), and a parallel walk computes all its chunks before
    /// it knows. Walking every star of at least kParallelPoints in parallel made bucky
    /// 128^3's last pass (one brick) 11 % slower on 2 threads than on 1.
    static constexpr size_t kSequentialPoints = 1024;
    std::vector<double> point_dev;

    // Scratch.
    std::vector<uint32_t> star_w, pts, pfrom, nbrs;
    std::vector<std::array<uint32_t, 4>> ntv;
    // The new tets' numerators, computed when a point is first tested against the tet:
    // an evaluation often leaves a target at its first points (cut above the cutoff).
    std::vector<Bary> nb;
    std::vector<uint8_t> nb_ready;
    // Per gathered point, the new tet that holds it: for the target being tried, and for
    // the best target so far (kept for the commit, with the evaluation that found it).
    std::vector<int> located, best_located;
    bool new_tets_of_best = false;  // ntv, nb, ... are the best target's
    uint32_t kept_w = kNil, kept_s = kNil, kept_stamp = 0;  // the evaluation kept, kNil: none
    std::vector<uint32_t> new_from;  // the star tet (index into star_w) a new tet comes from
    Pt new_at{0, 0, 0};               // the target of the new tets
    std::vector<int> old2new;
    std::vector<std::pair<double, uint32_t>> ranked;
    struct StarFace {
        mt::CornerPlane plane;
        std::array<uint32_t, 3> o;  // the corners other than w, in slot order
        int slot;                   // w's slot in the tet
        // For ranking targets by shape (filled only when they are ranked): the face's
        // corners in physical coordinates and its shortest edge, which no target changes.
        std::array<std::array<double, 3>, 3> phys;
        double shortest;
    };
    std::vector<StarFace> faces;

    /// Whole-grid coordinates of point p.
    Pt c(uint32_t p) const {
        const PointRec& r = point[p];
        return {origin[0] + r.at[0], origin[1] + r.at[1], origin[2] + r.at[2]};
    }
    std::array<double, 3> physical(uint32_t p) const {
        const Pt q = c(p);
        return {q[0] * vol.spacing[0], q[1] * vol.spacing[1], q[2] * vol.spacing[2]};
    }

    static Dims box_dims(const BrickBox& b) {
        return {b.hi[0] - b.lo[0] + 1, b.hi[1] - b.lo[1] + 1, b.hi[2] - b.lo[2] + 1};
    }
    BrickDecimator(const Volume& v, const MtBuildOptions& o, const BrickBox& b,
                   const std::vector<BrickMesh*>& in, NodeState& nd, BrickResult& r)
        : vol(v), opt(o), box(b), grid(box_dims(b)), whole(v.dims),
          origin{int32_t(b.lo[0]), int32_t(b.lo[1]), int32_t(b.lo[2])},
          box_points(uint32_t(grid.X * grid.Y * grid.Z)), input(in), nodes(nd), out(r) {}
    uint32_t global(uint32_t i) const {
        const Pt q = c(i);
        return whole.index(q[0], q[1], q[2]);
    }
    /// Box raster index of a whole-grid point.
    uint32_t local(uint32_t g) const {
        const Pt p = whole.coord(g);
        return grid.index(p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]);
    }
    /// Vertex id of the box point at raster index r, kNil if it is no input vertex.
    uint32_t vertex_at(uint32_t r) const {
        const uint64_t word = vertex_bits[r >> 6], below = (uint64_t(1) << (r & 63)) - 1;
        if (((word >> (r & 63)) & 1) == 0) return kNil;
        return vertices_before[r >> 6] + uint32_t(__builtin_popcountll(word & below));
    }

    // ---- samples --------------------------------------------------------------
    // A sample as the deviation reads it: `i` for integer data, `f` for floating point.
    struct Sample {
        int64_t i = 0;
        double f = 0;
    };
    Sample sample_at(uint32_t g) const {
        const double v = vol.value(g);
        return int_data ? Sample{int64_t(v), 0.0} : Sample{0, v};
    }
    int64_t ival(uint32_t p) const {
        const uint32_t bits = point[p].value;
        return slot == ValueSlot::Unsigned32 ? int64_t(bits) : int64_t(int32_t(bits));
    }
    double fval(uint32_t p) const {
        if (slot == ValueSlot::InVolume) return vol.value(global(p));
        float f;
        std::memcpy(&f, &point[p].value, sizeof f);
        return double(f);
    }
    Sample sample(uint32_t p) const { return int_data ? Sample{ival(p), 0.0} : Sample{0, fval(p)}; }
    /// Fills point p as the box point at raster index r.
    void set_point(uint32_t p, uint32_t r) {
        PointRec& rec = point[p];
        const Pt l = grid.coord(r);
        rec.at = {uint16_t(l[0]), uint16_t(l[1]), uint16_t(l[2])};
        const Pt q = c(p);
        rec.planes = whole.planes(q);
        bool f = false;
        for (int a = 0; a < 3; ++a) {
            const int64_t last = (a == 0 ? whole.X : a == 1 ? whole.Y : whole.Z) - 1;
            f |= (q[a] == box.lo[a] && box.lo[a] != 0) || (q[a] == box.hi[a] && box.hi[a] != last);
        }
        const uint32_t g = global(p);
        rec.frozen = f || (!nodes.pinned.empty() && nodes.pinned[g] != 0);
        const double v = vol.value(g);
        switch (slot) {
        case ValueSlot::Signed32: rec.value = uint32_t(int32_t(int64_t(v))); break;
        case ValueSlot::Unsigned32: rec.value = uint32_t(int64_t(v)); break;
        case ValueSlot::Float32: {
            const float f32 = float(v);
            std::memcpy(&rec.value, &f32, sizeof f32);
            break;
        }
        case ValueSlot::InVolume: break;
        }
    }

    // ---- corner chains -------------------------------------------------------
    template <class F>
    void for_star(uint32_t v, F f) const {
        for (uint32_t c = vhead[v]; c != kNil; c = next_corner[c]) f(c >> 2, c & 3);
    }
    // The walk is a chain of dependent loads (next_corner), but the tets and the point
    // records the caller reads next (each tet's corners, the head of its point block)
    // are known at each step: asking for them now overlaps their misses with the rest
    // of the walk.
    void gather_star(uint32_t v, std::vector<uint32_t>& out) const {
        out.clear();
        for (uint32_t c = vhead[v]; c != kNil;) {
            const TetRec& t = tets[c >> 2];
            for (const uint32_t u : t.v) __builtin_prefetch(&point[u]);
            if (t.head != kNil) __builtin_prefetch(&point[t.head]);
            out.push_back(c >> 2);
            c = next_corner[c];
        }
    }
    // The chains are doubly linked (TetRec::prev) so that unlinking does not walk the
    // chain from its head: each step of such a walk is a cache miss.
    void unlink_corner(uint32_t v, uint32_t corner) {
        const uint32_t before = tets[corner >> 2].prev[corner & 3], after = next_corner[corner];
        if (before == kNil) vhead[v] = after;
        else next_corner[before] = after;
        if (after != kNil) tets[after >> 2].prev[after & 3] = before;
    }
    void link_corner(uint32_t v, uint32_t corner) {
        const uint32_t first = vhead[v];
        next_corner[corner] = first;
        if (first != kNil) tets[first >> 2].prev[first & 3] = corner;
        tets[corner >> 2].prev[corner & 3] = kNil;
        vhead[v] = corner;
    }
    static int slot_of(const std::array<uint32_t, 4>& t, uint32_t v) {
        for (int i = 0; i < 4; ++i)
            if (t[i] == v) return i;
        return -1;
    }
    std::array<Pt, 4> pts_of(const std::array<uint32_t, 4>& t) const {
        return {c(t[0]), c(t[1]), c(t[2]), c(t[3])};
    }

    // ---- exact deviation of a sample from the interpolant of a tet ----------
    // d: barycentric numerators of the sample's point (sum = det > 0). Returns the
    // error as a double and whether it is exact.
    double deviation(const Sample& x, const std::array<uint32_t, 4>& t, const std::array<int64_t, 4>& d,
                     int64_t det, bool& exact) const {
        if (small_int) {  // |values| < 2^20 and |det| < 2^40: the numerator fits 64 bits
            int64_t num = x.i * det;
            for (int i = 0; i < 4; ++i) num -= ival(t[i]) * d[i];
            if (num < 0) num = -num;
            if (num == 0) return 0.0;
            exact = exact && num % det == 0 && num / det < (int64_t(1) << 53);
            return double(num) / double(det);
        }
        if (int_data) {
            __int128 num = __int128(x.i) * det;
            for (int i = 0; i < 4; ++i) num -= __int128(ival(t[i])) * d[i];
            if (num < 0) num = -num;
            if (num == 0) return 0.0;
            exact = exact && (num % det == 0) && num / det < (__int128(1) << 53);
            return double(num) / double(det);
        }
        double l = 0;
        for (int i = 0; i < 4; ++i) l += fval(t[i]) * double(d[i]);
        exact = false;
        return std::fabs(x.f - l / double(det));
    }

    // ---- setup ---------------------------------------------------------------
    void init() {
        int_data = !is_float(vol.type);
        small_int = vol.type == ValueType::U8 || vol.type == ValueType::I8 || vol.type == ValueType::U16 ||
                    vol.type == ValueType::I16;
        slot = vol.type == ValueType::U32   ? ValueSlot::Unsigned32
               : vol.type == ValueType::F32 ? ValueSlot::Float32
               : vol.type == ValueType::F64 ? ValueSlot::InVolume
                                            : ValueSlot::Signed32;
        // Which box points are vertices, and how many points the input's tets own.
        vertex_bits.assign((size_t(box_points) + 63) / 64, 0);
        size_t owned = 0, tet_count = 0;
        if (input.empty()) {
            for (uint32_t r = 0; r < box_points; ++r) vertex_bits[r >> 6] |= uint64_t(1) << (r & 63);
            tet_count = size_t(5) * size_t(grid.X - 1) * size_t(grid.Y - 1) * size_t(grid.Z - 1);
        } else {
            HandedTet t;
            for (const BrickMesh* b : input) {
                for (BrickMeshReader in(*b); in.next(t);)
                    for (uint32_t g : t.v) {
                        const uint32_t r = local(g);
                        vertex_bits[r >> 6] |= uint64_t(1) << (r & 63);
                    }
                owned += b->points;
                tet_count += b->tets;
            }
        }
        vertices_before.resize(vertex_bits.size());
        for (size_t i = 0; i < vertex_bits.size(); ++i) {
            vertices_before[i] = vertices;
            vertices += uint32_t(__builtin_popcountll(vertex_bits[i]));
        }
        // Room for every point removed by the end (the input's and the vertices'), twice,
        // as compact_owned() allows: the array never moves (a reservation is not resident).
        point.reserve(size_t(vertices) + 2 * (size_t(vertices) + owned) + kMinGarbage + 64);
        point.assign(size_t(vertices) + owned, PointRec{});
        for (size_t i = 0; i < vertex_bits.size(); ++i)
            for (uint64_t word = vertex_bits[i]; word != 0; word &= word - 1) {
                const uint32_t r = uint32_t(i * 64) + uint32_t(__builtin_ctzll(word));
                const uint32_t v = vertex_at(r);
                set_point(v, r);
                point[v].alive = 1;
            }
        tets.reserve(tet_count);
        if (input.empty()) {
            mt::for_each_reference_tet(grid, origin, [&](const std::array<uint32_t, 4>& t) { tets.push_back(TetRec{t}); });
        } else {
            uint32_t next_owned = vertices;
            HandedTet t;
            for (const BrickMesh* b : input)
                for (BrickMeshReader in(*b); in.next(t);) {
                    std::array<uint32_t, 4> lt;
                    for (int i = 0; i < 4; ++i) lt[i] = vertex_at(local(t.v[i]));
                    TetRec rec{lt};
                    rec.err = t.err;
                    rec.ferr = t.face_err;
                    // Keep each point list in its order (the evaluation's early exits see it).
                    rec.head = t.points > 0 ? next_owned : kNil;
                    rec.owned = t.points;
                    for (uint32_t k = 0; k < t.points; ++k) set_point(next_owned++, local(in.point()));
                    tets.push_back(rec);
                }
            // The children's meshes now live in `tets`: free them before the brick's own
            // arrays grow, so a pass never holds a mesh twice.
            for (BrickMesh* b : input) *b = BrickMesh{};
        }
        owned_live = owned;
        const size_t m = tets.size();
        next_corner.assign(4 * m, kNil);
        vhead.assign(vertices, kNil);
        for (size_t t = m; t-- > 0;)
            for (int i = 0; i < 4; ++i) link_corner(tets[t].v[i], uint32_t(4 * t + i));
        stamp.assign(vertices, 0);
        live_seq.assign(vertices, 0);
        no_target_from.assign(vertices, 0.0f);
    }

    void push_dirty(uint32_t w, double cost) {
        live_seq[w] = ++seq_counter;
        heap.push(Entry{cost, -INFINITY, w, kNil, live_seq[w], stamp[w], true, false});
    }

    // ---- link condition (docs/mt.md §2, "Legality") -------------------------
    // Simplices of a link as sorted unique keys: an edge (a < b) packs into 64 bits, a
    // triangle (a < b < c) into 128, so the sorts and intersections compare integers.
    using TriKey = unsigned __int128;
    static uint64_t edge_key(uint32_t a, uint32_t b) { return uint64_t(a) << 32 | b; }
    static TriKey tri_key(uint32_t a, uint32_t b, uint32_t c) {
        return TriKey(a) << 64 | TriKey(b) << 32 | c;
    }
    struct Link {
        std::vector<uint32_t> v0;
        std::vector<uint64_t> v1;
        std::vector<TriKey> v2;
        std::vector<uint64_t> bfaces;  // boundary faces (v,a,b) as edge keys of (a,b)
        std::vector<uint64_t> faces;   // scratch
        std::vector<uint64_t> ghost;   // scratch: edges (a, kOmega)
    };
    std::vector<uint32_t> e0_;
    std::vector<uint64_t> e1_;
    /// Links are a few dozen keys: an insertion sort beats std::sort's setup there
    /// (its sorts of 32-bit keys were 3.5 % of bucky 128^3's build).
    template <class T>
    static void sort_unique(std::vector<T>& x) {
        if (x.size() > 32) {
            std::sort(x.begin(), x.end());
        } else {
            for (size_t i = 1; i < x.size(); ++i) {
                const T key = x[i];
                size_t j = i;
                for (; j > 0 && key < x[j - 1]; --j) x[j] = x[j - 1];
                x[j] = key;
            }
        }
        x.erase(std::unique(x.begin(), x.end()), x.end());
    }
    /// Marks the vertices of Lk(v) `in_link` (link_ok clears them): each one is
    /// pushed once, not once per tet, so its sort is of a dozen entries.
    void build_link_marking(uint32_t v, Link& L) {
        L.v0.clear(), L.v1.clear(), L.v2.clear(), L.bfaces.clear();
        auto& faces = L.faces;
        faces.clear();
        for_star(v, [&](uint32_t t, uint32_t slot) {
            std::array<uint32_t, 3> o{};
            int k = 0;
            for (int i = 0; i < 4; ++i)
                if (i != int(slot)) o[k++] = tets[t].v[i];
            if (o[0] > o[1]) std::swap(o[0], o[1]);
            if (o[1] > o[2]) std::swap(o[1], o[2]);
            if (o[0] > o[1]) std::swap(o[0], o[1]);
            L.v2.push_back(tri_key(o[0], o[1], o[2]));
            for (const uint32_t u : o)
                if (!point[u].in_link) point[u].in_link = 1, L.v0.push_back(u);
            faces.push_back(edge_key(o[0], o[1])), faces.push_back(edge_key(o[0], o[2])),
                faces.push_back(edge_key(o[1], o[2]));
        });
        boundary_faces(faces, L.bfaces);
        if (!L.bfaces.empty()) L.v0.push_back(kOmega);
        auto& ghost = L.ghost;
        ghost.clear();
        for (const uint64_t f : L.bfaces) {
            const uint32_t a = uint32_t(f >> 32), b = uint32_t(f);
            ghost.push_back(edge_key(a, kOmega)), ghost.push_back(edge_key(b, kOmega));
            L.v2.push_back(tri_key(a, b, kOmega));
        }
        // The link's edges are the star's face edges, which boundary_faces has just
        // sorted: deduplicated and merged with the ghost edges (never equal to a real
        // one, as no vertex id is kOmega), they need no sort of their own.
        faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
        sort_unique(ghost);
        L.v1.resize(faces.size() + ghost.size());
        std::merge(faces.begin(), faces.end(), ghost.begin(), ghost.end(), L.v1.begin());
        sort_unique(L.v0), sort_unique(L.v2);
    }
    /// The faces (v, a, b) of the star around v, as edge keys of (a, b): those of one
    /// tet only are on the boundary. Sorts `faces`; appends the boundary ones to `out`.
    static void boundary_faces(std::vector<uint64_t>& faces, std::vector<uint64_t>& out) {
        std::sort(faces.begin(), faces.end());
        for (size_t i = 0; i < faces.size();) {
            size_t j = i;
            while (j < faces.size() && faces[j] == faces[i]) ++j;
            if (j - i == 1) out.push_back(faces[i]);
            i = j;
        }
    }
    /// |x ∩ y| for sorted unique ranges, stopping once it exceeds `limit`.
    template <class T>
    static size_t common_count(const std::vector<T>& x, const std::vector<T>& y, size_t limit) {
        size_t i = 0, j = 0, n = 0;
        while (i < x.size() && j < y.size() && n <= limit) {
            if (x[i] < y[j]) ++i;
            else if (y[j] < x[i]) ++j;
            else ++n, ++i, ++j;
        }
        return n;
    }
    Link lw_, ls_;
    BrickResult::Stats& st = out.stats;
    /// Lk(s) cut to the simplices whose vertices are all vertices of Lk(w) (marked
    /// `in_link`; ω when `omega`): a simplex of Lk(w) has only such vertices, so the
    /// intersection with Lk(w), all link_ok counts, is that of the whole Lk(s), for
    /// sorts of a few keys instead of the whole link. ω is a vertex of Lk(s) when s has
    /// a boundary face; that needs every face of its star, so only when ω is in Lk(w).
    void build_link_within(uint32_t s, bool omega, Link& L) const {
        L.v0.clear(), L.v1.clear(), L.v2.clear(), L.bfaces.clear();
        auto& faces = L.faces;
        faces.clear();
        for_star(s, [&](uint32_t t, uint32_t slot) {
            std::array<uint32_t, 3> o{};
            int k = 0;
            for (int i = 0; i < 4; ++i)
                if (i != int(slot)) o[size_t(k++)] = tets[t].v[size_t(i)];
            if (o[0] > o[1]) std::swap(o[0], o[1]);
            if (o[1] > o[2]) std::swap(o[1], o[2]);
            if (o[0] > o[1]) std::swap(o[0], o[1]);
            const bool m0 = point[o[0]].in_link, m1 = point[o[1]].in_link, m2 = point[o[2]].in_link;
            if (m0 && m1 && m2) L.v2.push_back(tri_key(o[0], o[1], o[2]));
            if (m0 && m1) L.v1.push_back(edge_key(o[0], o[1]));
            if (m0 && m2) L.v1.push_back(edge_key(o[0], o[2]));
            if (m1 && m2) L.v1.push_back(edge_key(o[1], o[2]));
            if (m0) L.v0.push_back(o[0]);
            if (m1) L.v0.push_back(o[1]);
            if (m2) L.v0.push_back(o[2]);
            if (omega)
                faces.push_back(edge_key(o[0], o[1])), faces.push_back(edge_key(o[0], o[2])),
                    faces.push_back(edge_key(o[1], o[2]));
        });
        if (omega) {
            boundary_faces(faces, L.bfaces);
            if (!L.bfaces.empty()) L.v0.push_back(kOmega);
            for (const uint64_t f : L.bfaces) {
                const uint32_t a = uint32_t(f >> 32), b = uint32_t(f);
                const bool ma = point[a].in_link, mb = point[b].in_link;
                if (ma) L.v1.push_back(edge_key(a, kOmega));
                if (mb) L.v1.push_back(edge_key(b, kOmega));
                if (ma && mb) L.v2.push_back(tri_key(a, b, kOmega));
            }
        }
        sort_unique(L.v0), sort_unique(L.v1), sort_unique(L.v2);
    }
    bool link_ok(uint32_t w, uint32_t s) {
        build_link_marking(w, lw_);
        const bool omega = !lw_.v0.empty() && lw_.v0.back() == kOmega;
        build_link_within(s, omega, ls_);
        for (const uint32_t u : lw_.v0)
            if (u != kOmega) point[u].in_link = 0;
        // Link of edge ws.
        auto& e0 = e0_;
        auto& e1 = e1_;
        e0.clear(), e1.clear();
        for_star(w, [&](uint32_t t, uint32_t) {
            if (slot_of(tets[t].v, s) < 0) return;
            std::array<uint32_t, 2> ab{};
            int k = 0;
            for (int i = 0; i < 4; ++i)
                if (tets[t].v[i] != w && tets[t].v[i] != s) ab[k++] = tets[t].v[i];
            if (ab[0] > ab[1]) std::swap(ab[0], ab[1]);
            e1.push_back(edge_key(ab[0], ab[1]));
            e0.push_back(ab[0]), e0.push_back(ab[1]);
        });
        bool boundary_edge = false;
        for (const uint64_t f : lw_.bfaces) {
            const uint32_t fa = uint32_t(f >> 32), fb = uint32_t(f);
            if (fa == s || fb == s) {
                const uint32_t a = fa == s ? fb : fa;
                e1.push_back(edge_key(a, kOmega));
                e0.push_back(a);
                boundary_edge = true;
            }
        }
        if (boundary_edge) e0.push_back(kOmega);
        sort_unique(e0), sort_unique(e1);
        // Lk(ws) is always in Lk(w) ∩ Lk(s), so the condition is that the intersection
        // has no more vertices and edges than Lk(ws), and no triangle.
        if (common_count(lw_.v0, ls_.v0, e0.size()) != e0.size()) return false;
        if (common_count(lw_.v1, ls_.v1, e1.size()) != e1.size()) return false;
        if (common_count(lw_.v2, ls_.v2, 0) != 0) return false;
        return true;
    }

    // ---- candidate evaluation (docs/mt.md §2, "Order") -----------------------
    /// faces[i]: the face of star_w[i] opposite w, with the tet's orientation as an
    /// affine function of w's position (a target is legal for the tet iff it is > 0).
    void star_faces(uint32_t w) {
        faces.resize(star_w.size());
        for (size_t i = 0; i < star_w.size(); ++i) {
            const auto& v = tets[star_w[i]].v;
            StarFace& f = faces[i];
            f.slot = slot_of(v, w);
            int k = 0;
            for (int j = 0; j < 4; ++j)
                if (j != f.slot) f.o[size_t(k++)] = v[size_t(j)];
            // The plane needs the face's three corners only (w's own position is not read).
            f.plane = mt::corner_plane_of_face(c(f.o[0]), c(f.o[1]), c(f.o[2]), f.slot);
        }
    }
    // Builds the new tets of w -> s into ntv/new_from/old2new (star_faces(w) first);
    // false if one is not positive. The face of each star tet opposite w gives one of a
    // new tet's four numerators and its determinant (bary).
    bool make_new_tets(uint32_t s) {
        // Sized once and cut to length: this runs for most targets an evaluation tries.
        const size_t m = star_w.size();
        ntv.resize(m), new_from.resize(m), old2new.resize(m);
        if (nb.size() < m) nb.resize(m);
        new_at = c(s);
        size_t n = 0;
        for (size_t i = 0; i < m; ++i) {
            const StarFace& f = faces[i];
            old2new[i] = -1;
            if (f.o[0] == s || f.o[1] == s || f.o[2] == s) continue;
            if (f.plane.at(new_at) <= 0) return false;
            auto& t = ntv[n];
            t = tets[star_w[i]].v;
            t[size_t(f.slot)] = s;
            old2new[i] = int(n);
            new_from[n++] = uint32_t(i);
        }
        ntv.resize(n), new_from.resize(n);
        nb_ready.assign(ntv.size(), 0);
        return true;
    }
    /// The numerators of new tet j (make_new_tets), computed on first use.
    const Bary& bary(size_t j) {
        // Most calls find it ready (the locate loops ask every new tet per point): the test
        // stays inline, the computation does not.
        if (nb_ready[j]) [[likely]] return nb[j];
        return make_bary(j);
    }
    [[gnu::noinline]] const Bary& make_bary(size_t j) {
        Bary& b = nb[j];
        {
            const StarFace& f = faces[new_from[j]];
            std::array<Pt, 4> p;
            for (int k = 0; k < 4; ++k) p[size_t(k)] = k == f.slot ? new_at : c(ntv[j][size_t(k)]);
            b.set_moved(p, f.slot, f.plane, f.plane.at(new_at));
            nb_ready[j] = 1;
        }
        return b;
    }
    // Index of the first new tet containing p (guess first), -1 if none.
    int locate(uint32_t p, int guess, std::array<int64_t, 4>& d) {
        const Pt q = c(p);
        if (guess >= 0 && bary(size_t(guess)).locate(q, d)) return guess;
        for (size_t j = 0; j < ntv.size(); ++j)
            if (int(j) != guess && bary(j).locate(q, d)) return int(j);
        return -1;
    }

    /// pts: w, then each star tet's owned points in its list order (pfrom: the star
    /// tet). The blocks lie anywhere in `point`: their first lines are asked for before
    /// the copy, and the hardware prefetcher follows each block.
    void gather_points(uint32_t w) {
        size_t total = 1;
        for (const uint32_t t : star_w) {
            const TetRec& r = tets[t];
            if (r.owned > 0) __builtin_prefetch(&point[r.head]), total += r.owned;
        }
        pts.resize(total), pfrom.resize(total);
        pts[0] = w, pfrom[0] = kNil;
        size_t at = 1;
        for (size_t i = 0; i < star_w.size(); ++i) {
            const TetRec& r = tets[star_w[i]];
            for (uint32_t k = 0; k < r.owned; ++k, ++at) pts[at] = r.head + k, pfrom[at] = uint32_t(i);
        }
    }

    /// Best target of w by (cost, shape ratio, id); with check_link, the best one that
    /// also passes the link condition (otherwise the caller checks before committing).
    /// Fast deviation for ranking candidates (exactness is only tracked at commit).
    double quick_deviation(uint32_t p, const std::array<uint32_t, 4>& t, const std::array<int64_t, 4>& d,
                           int64_t det) const {
        if (small_int) {
            int64_t num = ival(p) * det;
            for (int i = 0; i < 4; ++i) num -= ival(t[i]) * d[i];
            return double(num < 0 ? -num : num) / double(det);
        }
        bool exact = true;
        return deviation(sample(p), t, d, det, exact);
    }

    /// The rest of evaluate's target walk, from point `from` on (the points before it
    /// were walked on this thread without ending the walk), on the arena's threads:
    /// locate each point in the target's new tets and take its deviation;
    /// the walk ends at the first point that no new tet holds (ok = false) or whose
    /// deviation is over the limit (over = true, cost = the maximum up to it). Same
    /// answer as the sequential loop: over_limit is monotone and the cost so far was
    /// not over it, so the running maximum first passes the limit at the first point
    /// whose own deviation does. Points after the end may be computed, never used
    /// (located[] is read only when the walk got through every point).
    template <class OverLimit>
    void walk_points_in_parallel(size_t from, const OverLimit& over_limit, double& cost, bool& ok, bool& over) {
        ++st.parallel_walks;
        for (size_t j = 0; j < ntv.size(); ++j) bary(j);  // every numerator now: the walk only reads
        point_dev.resize(pts.size());
        std::atomic<size_t> first_end{pts.size()};
        tbb::parallel_for(
            tbb::blocked_range<size_t>(from, pts.size(), kPointGrain),
            [&](const tbb::blocked_range<size_t>& r) {
                std::array<int64_t, 4> d;
                for (size_t i = r.begin(); i < r.end(); ++i) {
                    if (i > first_end.load(std::memory_order_relaxed)) return;
                    const int guess = pfrom[i] == kNil ? -1 : old2new[pfrom[i]];
                    const int j = locate(pts[i], guess, d);
                    located[i] = j;
                    point_dev[i] = j < 0 ? 0.0 : quick_deviation(pts[i], ntv[size_t(j)], d, nb[size_t(j)].det);
                    if (j < 0 || over_limit(point_dev[i])) {
                        for (size_t seen = first_end.load(); i < seen && !first_end.compare_exchange_weak(seen, i);) {
                        }
                        return;
                    }
                }
            },
            tbb::simple_partitioner());
        const size_t end = first_end.load();
        for (size_t i = from; i < end; ++i) cost = std::max(cost, point_dev[i]);
        st.located += (end == pts.size() ? end : end + 1) - from;
        if (end == pts.size()) return;
        if (located[end] < 0) ok = false;
        else cost = std::max(cost, point_dev[end]), over = true;
    }

    /// Cutoff: targets whose cost exceeds it are abandoned early; if all are, the
    /// result is `partial` with a lower bound (docs/mt.md §2, "Order").
    Candidate evaluate(uint32_t w, bool check_link, double cutoff = std::numeric_limits<double>::infinity()) {
        ++st.evaluations;
        kept_w = kNil;
        gather_star(w, star_w);
        st.star_tets += star_w.size();
        // The points are gathered only when a target gets past the face errors of the
        // link: when those alone exceed the cutoff, no point is needed (a lower bound).
        bool gathered = false;
        double link_max = 0;
        // Per star tet: the orientation of the tet with w moved to x (a legal target
        // keeps every one positive) and its corners other than w. The neighbours are
        // collected with a flag in their point records (read for the planes anyway), cleared
        // once they are; their order does not matter (ranked is sorted).
        star_faces(w);
        // Sized for every corner and cut to length: push_back is not inlined here, and
        // this loop runs over every corner of every star evaluated.
        nbrs.resize(3 * star_w.size());
        size_t nn = 0;
        for (size_t i = 0; i < star_w.size(); ++i) {
            const StarFace& f = faces[i];
            link_max = std::max(link_max, double(tets[star_w[i]].ferr[size_t(f.slot)]));
            for (const uint32_t u : f.o)
                if (!point[u].collected) point[u].collected = 1, nbrs[nn++] = u;
        }
        nbrs.resize(nn);
        for (uint32_t u : nbrs) point[u].collected = 0;
        // Rank the geometrically legal targets by shape first: a later target then
        // wins only with a strictly smaller error, so ties stop scanning at once.
        // When the link's face errors alone exceed the cutoff, every target is cut there:
        // the answer is that lower bound if some target is legal, so the first legal one
        // settles it and no shape is ranked (most evaluations end here).
        const bool all_cut = link_max > cutoff;
        const bool shaped = !all_cut || opt.max_shape_ratio > 0;
        const double cap2 = opt.max_shape_ratio * opt.max_shape_ratio;
        ranked.clear();
        if (shaped)
            for (StarFace& f : faces) {
                for (int k = 0; k < 3; ++k) f.phys[size_t(k)] = physical(f.o[size_t(k)]);
                f.shortest = mt::face_shortest_squared(f.phys[0], f.phys[1], f.phys[2]);
            }
        // A target is legal iff no face refuses it, whatever the order they are asked in:
        // the face that refused the previous target is asked first, since neighbouring
        // targets tend to lie beyond the same face (most targets are refused).
        size_t refused_by = 0;
        auto refuses = [&](const StarFace& f, uint32_t s, const Pt& cs) {
            return f.o[0] != s && f.o[1] != s && f.o[2] != s && f.plane.at(cs) <= 0;
        };
        for (uint32_t s : nbrs) {
            if ((point[w].planes & ~point[s].planes) != 0 || point[s].frozen) continue;
            const Pt cs = c(s);
            if (refuses(faces[refused_by], s, cs)) continue;
            bool legal = true;
            for (size_t i = 0; i < faces.size(); ++i)
                if (i != refused_by && refuses(faces[i], s, cs)) {
                    legal = false;
                    refused_by = i;
                    break;
                }
            if (!legal) continue;
            double q2 = 0;
            if (shaped) {
                // The worst new tet; a target over the cap is refused as soon as one is.
                const auto ps = physical(s);
                const bool capped = opt.max_shape_ratio > 0;
                for (const StarFace& f : faces)
                    if (f.o[0] != s && f.o[1] != s && f.o[2] != s) {
                        q2 = std::max(q2, mt::shape_ratio_squared(ps, f.phys[0], f.phys[1], f.phys[2], f.shortest));
                        if (capped && q2 > cap2) break;
                    }
                if (capped && q2 > cap2) continue;
            }
            ranked.push_back({std::sqrt(q2), s});
            if (all_cut) break;
        }
        st.ranked += ranked.size();
        if (all_cut) {
            ++st.cut_at_link;
            Candidate c;
            if (!ranked.empty()) c.partial = true, c.cost = link_max, c.quality = -INFINITY;
            else c.none_from = -INFINITY;  // no legal target at all
            return c;
        }
        std::sort(ranked.begin(), ranked.end());
        std::vector<uint32_t> excluded;
        for (;;) {
            Candidate best;
            double lower = std::numeric_limits<double>::infinity();
            bool cut = false;
            for (const auto& [q, s] : ranked) {
                if (std::find(excluded.begin(), excluded.end(), s) != excluded.end()) continue;
                // With a best, this target must be strictly cheaper; else not above the cutoff.
                auto over_limit = [&](double c) { return best.ok ? c >= best.cost : c > cutoff; };
                double cost = link_max;
                if (over_limit(cost)) {
                    if (!best.ok) cut = true, lower = std::min(lower, cost);
                    continue;
                }
                if (!gathered) {
                    gather_points(w);
                    st.gathered += pts.size();
                    gathered = true;
                }
                make_new_tets(s);
                new_tets_of_best = false;
                ++st.tried;
                bool ok = true, over = false;
                std::array<int64_t, 4> d;
                located.resize(pts.size());
                const bool split_walk = pts.size() >= kSequentialPoints + kParallelPoints && parallel_points();
                const size_t walked_here = split_walk ? kSequentialPoints : pts.size();
                for (size_t i = 0; i < walked_here; ++i) {
                    const int guess = pfrom[i] == kNil ? -1 : old2new[pfrom[i]];
                    const int j = locate(pts[i], guess, d);
                    located[i] = j;
                    ++st.located;
                    if (j < 0) {
                        ok = false;
                        break;
                    }
                    cost = std::max(cost, quick_deviation(pts[i], ntv[j], d, nb[size_t(j)].det));
                    if (over_limit(cost)) {
                        over = true;
                        break;
                    }
                }
                if (split_walk && ok && !over) walk_points_in_parallel(walked_here, over_limit, cost, ok, over);
                if (!ok) continue;
                if (over) {
                    if (!best.ok) cut = true, lower = std::min(lower, cost);
                    continue;
                }
                best.ok = true, best.cost = cost, best.quality = q, best.s = s;
                std::swap(located, best_located);
                new_tets_of_best = true;
            }
            if (!best.ok) {
                if (cut) best.partial = true, best.cost = lower, best.quality = -INFINITY;
                // Every ranked target failed to hold a point before its cost passed the
                // cutoff, so it fails the same way under any higher cutoff (costs only grow
                // along the points); without a ranked target no cutoff matters.
                else if (excluded.empty()) best.none_from = ranked.empty() ? -INFINITY : cutoff;
                return best;
            }
            best.link_free = excluded.empty();
            if (!check_link || link_ok(w, best.s)) {
                kept_w = w, kept_s = best.s, kept_stamp = stamp[w];
                return best;
            }
            excluded.push_back(best.s);
        }
    }

    // ---- commit w -> s --------------------------------------------------------
    std::vector<uint32_t> star_s_scratch, mask_perm, newid, link;
    std::vector<std::array<float, 4>> new_face_err;
    std::vector<double> new_err;
    std::vector<uint8_t> new_exact;
    std::vector<mt::StarKey> mask_keys;

    MtHistory::Tet node_tet(const std::array<uint32_t, 4>& t) const {
        return {nodes.node[global(t[0])], nodes.node[global(t[1])], nodes.node[global(t[2])], nodes.node[global(t[3])]};
    }

    // ---- owned point blocks ----------------------------------------------------
    std::vector<uint32_t> block_fill;  // per new tet: its block's size, start, fill
    std::vector<uint64_t> block_order;
    static constexpr size_t kMinGarbage = size_t(1) << 14;  // records; fewer are never squeezed
    void drop_owned(uint32_t t) {
        owned_live -= tets[t].owned, owned_garbage += tets[t].owned;
        tets[t].head = kNil;
        tets[t].owned = 0;
    }
    /// The relocated points (pts, their new tets in `located`) as one block per new tet
    /// at the end of `point`, each in reverse pts order: the order in which pushing
    /// them on the front of linked lists left them (the order, and so every later
    /// evaluation's early exits and the output bytes, are as before the blocks).
    void write_owned_blocks() {
        block_fill.assign(ntv.size() + 1, 0);
        for (size_t i = 0; i < pts.size(); ++i) ++block_fill[size_t(located[i]) + 1];
        const size_t base = point.size();
        for (size_t j = 0; j < ntv.size(); ++j) {
            const uint32_t t = newid[j], n = block_fill[j + 1];
            tets[t].head = n > 0 ? uint32_t(base + block_fill[j]) : kNil;
            tets[t].owned = n;
            block_fill[j + 1] += block_fill[j];  // now the block's start, then its fill
        }
        point.resize(base + pts.size());
        for (size_t i = pts.size(); i-- > 0;) {
            PointRec& r = point[base + block_fill[size_t(located[i])]++];
            r = point[pts[i]];
            r.alive = 0;  // a copy of w's vertex record is no vertex
        }
        owned_live += pts.size();
    }
    /// Squeezes the dead blocks out of `point` (blocks slide down in address order):
    /// commit calls it once they outweigh the live ones, or when its new blocks would
    /// not fit the reservation, so the array stays within twice its live size.
    void compact_owned() {
        ++st.compactions;
        block_order.clear();
        for (uint32_t t = 0; t < tets.size(); ++t)
            if (tets[t].owned > 0) block_order.push_back(uint64_t(tets[t].head) << 32 | t);
        std::sort(block_order.begin(), block_order.end());
        size_t at = vertices;
        for (const uint64_t key : block_order) {
            TetRec& r = tets[uint32_t(key)];
            std::copy(point.begin() + r.head, point.begin() + r.head + r.owned, point.begin() + ptrdiff_t(at));
            r.head = uint32_t(at);
            at += r.owned;
        }
        point.resize(at);
        owned_garbage = 0;
    }

    void commit(uint32_t w, uint32_t s) {
        // Most collapses are committed right after the evaluation that chose them (its
        // entry is the heap's next): w's star is then the one evaluated (same stamp), and
        // the scratch still holds its star, faces and points, and where the chosen target's
        // new tets hold each point. Reusing them gives the same values by construction.
        const bool reuse = kept_w == w && kept_s == s && kept_stamp == stamp[w];
        kept_w = kNil;
        if (reuse) {
            ++st.commits_reused;
        } else {
            gather_star(w, star_w);
            gather_points(w);
        }
        // The new blocks go at the end of `point`: squeeze the dead ones out first when
        // they outweigh the live ones or the new ones would not fit (the last collapses
        // move up to all the points: growing the array would hold it twice). Blocks keep
        // their order inside, so the points gathered again are the same sequence.
        if (owned_garbage > std::max<size_t>(owned_live, kMinGarbage) || point.size() + pts.size() > point.capacity()) {
            compact_owned();
            gather_points(w);
        }
        MtHistory* hist = opt.record_history ? &out.history : nullptr;
        if (hist) {
            std::vector<MtHistory::Tet> before;
            for (uint32_t t : star_w) before.push_back(node_tet(tets[t].v));
            for_star(s, [&](uint32_t t, uint32_t) {
                if (slot_of(tets[t].v, w) < 0) before.push_back(node_tet(tets[t].v));
            });
            hist->before.push_back(std::move(before));
        }
        // Every tet whose corners, chains, errors or points change below is one of w's:
        // their vertices are the ones whose next evaluation may differ.
        for (const uint32_t t : star_w)
            for (const uint32_t v : tets[t].v) point[v].no_target = 0, point[v].same_best = 0;
        if (!reuse) star_faces(w);
        if ((!reuse || !new_tets_of_best) && !make_new_tets(s))
            throw Error(ErrorCode::CorruptData, "mt build: internal error (orientation)");
        // Face errors inherited by the new tets (see the file comment).
        auto& nf = new_face_err;
        auto& ne = new_err;
        auto& nexact = new_exact;
        nf.assign(ntv.size(), {0, 0, 0, 0});
        ne.assign(ntv.size(), 0.0);
        nexact.assign(ntv.size(), 1);
        for (size_t i = 0; i < star_w.size(); ++i) {
            const uint32_t t = star_w[i];
            const int sw = slot_of(tets[t].v, w);
            if (old2new[i] >= 0) {
                nf[old2new[i]][sw] = tets[t].ferr[sw];
                continue;
            }
            // Edge tet (w,s,a,b): its face sab (opposite w) is a face of one new tet.
            std::array<uint32_t, 2> ab{};
            int k = 0;
            for (int j = 0; j < 4; ++j)
                if (tets[t].v[j] != w && tets[t].v[j] != s) ab[k++] = tets[t].v[j];
            for (size_t j = 0; j < ntv.size(); ++j) {
                const int sa = slot_of(ntv[j], ab[0]), sb = slot_of(ntv[j], ab[1]);
                if (sa < 0 || sb < 0) continue;
                const int opp = 6 - sa - sb - slot_of(ntv[j], s);
                nf[j][opp] = std::max(nf[j][opp], tets[t].ferr[sw]);
            }
        }
        // Unlink the old star of w.
        for (size_t i = 0; i < star_w.size(); ++i) {
            const uint32_t t = star_w[i];
            if (old2new[i] >= 0) continue;
            for (int j = 0; j < 4; ++j)
                if (tets[t].v[j] != w) unlink_corner(tets[t].v[j], 4 * t + j);
            drop_owned(t);
            tets[t].dead = true;
        }
        newid.assign(ntv.size(), 0);
        for (size_t i = 0; i < star_w.size(); ++i) {
            const uint32_t t = star_w[i];
            if (old2new[i] < 0) continue;
            const int sw = slot_of(tets[t].v, w);
            tets[t].v[sw] = s;
            link_corner(s, 4 * t + sw);
            drop_owned(t);
            newid[old2new[i]] = t;
        }
        vhead[w] = kNil;
        // Relocate the points.
        auto account = [&](const Sample& x, int jj, const std::array<int64_t, 4>& dd) {
            bool exact = true;
            const double dev = deviation(x, ntv[jj], dd, bary(size_t(jj)).det, exact);
            if (dev > ne[jj]) ne[jj] = dev;
            if (!exact) nexact[jj] = false;
            const float fd = mt::round_up_float(dev, exact);
            for (int k = 0; k < 4; ++k)
                if (dd[k] == 0) nf[jj][k] = std::max(nf[jj][k], fd);
        };
        std::array<int64_t, 4> d;
        located.resize(pts.size());  // scratch again (a reused evaluation's answer is best_located)
        for (size_t i = 0; i < pts.size(); ++i) {
            const uint32_t p = pts[i];
            // The evaluation's answer is the first tet holding p (guess first): tried first,
            // it is the answer again.
            const int guess = reuse ? best_located[i] : pfrom[i] == kNil ? -1 : old2new[pfrom[i]];
            const int j = locate(p, guess, d);
            if (j < 0) throw Error(ErrorCode::CorruptData, "mt build: internal error (point lost)");
            located[i] = j;
            const Sample x = sample(p);
            account(x, j, d);
            if (d[0] == 0 || d[1] == 0 || d[2] == 0 || d[3] == 0) {
                std::array<int64_t, 4> d2;
                const Pt cp = c(p);
                for (size_t k = 0; k < ntv.size(); ++k)
                    if (int(k) != j && bary(k).locate(cp, d2)) account(x, int(k), d2);
            }
        }
        write_owned_blocks();
        // A removed point on an edge of a new tet can be owned by a tet outside the star
        // that shares only that edge: it is then neither relocated here nor on a face
        // whose error is inherited. Its deviation is the same in every tet around the
        // edge (on an edge the interpolant depends on the two ends only), so each new
        // tet takes it from the lattice points of its own edges. Edges of at most one
        // cell per axis, most of them, have none.
        for (size_t j = 0; j < ntv.size(); ++j)
            for (int e0 = 0; e0 < 3; ++e0)
                for (int e1 = e0 + 1; e1 < 4; ++e1) {
                    const Pt a = c(ntv[j][e0]);
                    const Pt b = c(ntv[j][e1]);
                    const int64_t dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
                    if ((std::abs(dx) | std::abs(dy) | std::abs(dz)) <= 1) continue;
                    const int64_t g = std::gcd(std::gcd(std::abs(dx), std::abs(dy)), std::abs(dz));
                    for (int64_t k = 1; k < g; ++k) {
                        const Pt q{int32_t(a[0] + dx / g * k), int32_t(a[1] + dy / g * k), int32_t(a[2] + dz / g * k)};
                        // The point may be owned by a tet of another brick: its sample comes
                        // from the volume, and only a vertex has an id here.
                        const uint32_t v = vertex_at(grid.index(q[0] - origin[0], q[1] - origin[1], q[2] - origin[2]));
                        if (v != kNil && point[v].alive && v != w) continue;  // a vertex: no deviation
                        std::array<int64_t, 4> dd;
                        if (!bary(j).locate(q, dd)) throw Error(ErrorCode::CorruptData, "mt build: internal error (edge point)");
                        account(sample_at(whole.index(q[0], q[1], q[2])), int(j), dd);
                    }
                }
        for (size_t j = 0; j < ntv.size(); ++j) {
            const uint32_t t = newid[j];
            float e = mt::round_up_float(ne[j], nexact[j]);
            for (int k = 0; k < 4; ++k) e = std::max(e, nf[j][k]);
            tets[t].err = e;
            tets[t].ferr = nf[j];
        }
        // The new node at s.
        const uint32_t k = uint32_t(out.updates.size());
        const uint32_t gs = global(s), gw = global(w);
        uint32_t label = std::max(nodes.label[gs], nodes.label[gw]);
        float err = std::max(nodes.err[gs], nodes.err[gw]);
        gather_star(s, star_s_scratch);
        link.resize(3 * star_s_scratch.size());  // cut to length below (no push_back per corner)
        size_t nl = 0;
        for (uint32_t t : star_s_scratch) {
            err = std::max(err, tets[t].err);
            for (int i = 0; i < 4; ++i)
                if (tets[t].v[i] != s) link[nl++] = tets[t].v[i];
        }
        link.resize(nl);
        std::sort(link.begin(), link.end());
        link.erase(std::unique(link.begin(), link.end()), link.end());
        for (uint32_t u : link) label = std::max(label, nodes.label[global(u)]);
        label += 1;
        // Split mask over the canonically ordered star.
        mt::star_order(star_s_scratch, s, c(s), c(w), [&](uint32_t v) { return c(v); },
                       [&](uint32_t t) -> const std::array<uint32_t, 4>& { return tets[t].v; }, mask_perm,
                       mask_keys);
        MtUpdate u;
        u.w = gw, u.s = gs, u.label = label, u.error = err, u.star = uint32_t(star_s_scratch.size());
        for (uint32_t r = 0; r < mask_perm.size(); ++r) {
            const uint32_t t = star_s_scratch[mask_perm[r]];
            const bool wside = std::find(newid.begin(), newid.end(), t) != newid.end();
            const uint64_t b = mask_bit_count++;
            if ((b >> 6) >= out.mask_bits.size()) out.mask_bits.push_back(0);
            if (wside) out.mask_bits[b >> 6] |= uint64_t(1) << (b & 63);
        }
        out.updates.push_back(u);
        // Straight into the whole volume's state: s is free, so no other brick of this
        // pass reads or writes its entry (mt_decimate.hpp).
        nodes.node[gs] = kProvisional + k;
        nodes.label[gs] = label;
        nodes.err[gs] = err;
        point[w].alive = 0;
        ++stamp[w];
        live_seq[w] = 0;
        if (hist) {
            std::vector<MtHistory::Tet> after;
            for (uint32_t t : star_s_scratch) after.push_back(node_tet(tets[t].v));
            hist->after.push_back(std::move(after));
            hist->update_of_node.push_back(k);
        }
        link.push_back(s);
        for (uint32_t v : link) {
            ++stamp[v];
            if (live_seq[v] == 0 && !point[v].frozen) push_dirty(v, current_cost);
        }
    }
    uint64_t mask_bit_count = 0;
    double current_cost = 0;

    void run(const BrickProgress& progress) {
        init();
        uint64_t candidates = 0;
        for (uint32_t v = 0; v < vertices; ++v) candidates += point[v].alive && !point[v].frozen;
        // The heap holds at most one entry per free vertex (a vertex is pushed only when
        // it has none: live_seq == 0), and each collapse removes one free vertex: sized
        // once, neither grows by doubling (up to twice the entries, and both blocks while
        // copying). Same pushes and pops, so the same order.
        {
            std::vector<Entry> storage;
            storage.reserve(candidates);
            heap = std::priority_queue<Entry>(std::less<Entry>(), std::move(storage));
        }
        out.updates.reserve(candidates);
        for (uint32_t v = 0; v < vertices; ++v)
            if (point[v].alive && !point[v].frozen) push_dirty(v, 0.0);
        while (!heap.empty()) {
            const Entry e = heap.top();
            heap.pop();
            if (e.seq != live_seq[e.w] || !point[e.w].alive) continue;
            live_seq[e.w] = 0;
            current_cost = std::max(current_cost, std::min(e.cost, opt.max_error));
            const bool fresh = !e.dirty && e.stamp == stamp[e.w];
            if (fresh && e.cost > opt.max_error) break;  // fresh keys are exact or lower bounds
            if (!fresh || e.partial || !link_ok(e.w, e.s)) {
                const double cutoff = heap.empty() ? INFINITY : heap.top().cost;
                const bool check_link = fresh && !e.partial;
                // An evaluation known to find no target again is skipped: it would push
                // nothing, so the heap, hence every later step, is the same without it.
                // (Most of them come from a neighbour's collapse that bumped w's stamp
                // without touching w's star; in the last passes they are a quarter of all.)
                if (!check_link && point[e.w].no_target && cutoff >= double(no_target_from[e.w])) {
                    ++st.skipped;
                    point[e.w].same_best = 0;
                    continue;
                }
                // Likewise an exact entry whose stamp alone changed: w's star is the one its
                // evaluation saw, which found the first target of least cost in rank order,
                // without the link test deciding; any cutoff of at least that cost finds it
                // again. The entry the evaluation would push is pushed as it would be.
                if (!check_link && !e.dirty && !e.partial && point[e.w].same_best && cutoff >= e.cost) {
                    ++st.repeated;
                    live_seq[e.w] = ++seq_counter;
                    heap.push(Entry{e.cost, e.quality, e.w, e.s, live_seq[e.w], stamp[e.w], false, false});
                    continue;
                }
                const Candidate c = evaluate(e.w, check_link, cutoff);
                point[e.w].same_best = c.ok && c.link_free;
                if (!c.ok && !c.partial && c.none_from != INFINITY) {
                    point[e.w].no_target = 1;
                    no_target_from[e.w] = c.none_from == -INFINITY ? -INFINITY : mt::round_up_float(c.none_from, true);
                }
                if (c.ok || c.partial) {
                    live_seq[e.w] = ++seq_counter;
                    heap.push(Entry{c.cost, c.quality, e.w, c.partial ? kNil : c.s, live_seq[e.w], stamp[e.w],
                                    false, c.partial});
                }
                continue;
            }
            if (e.cost > opt.max_error) break;
            commit(e.w, e.s);
            ++st.commits;
            if (progress && st.commits % kCollapsesPerReport == 0) progress(st.commits, candidates);
        }
        // The decimated mesh, in slot order (the node state is already in `nodes`).
        BrickMesh& mesh = out.mesh;
        HandedTet h;
        std::vector<uint32_t> owned;
        auto hand_over = [&](uint32_t t) {
            for (int i = 0; i < 4; ++i) h.v[i] = global(tets[t].v[i]);
            h.err = tets[t].err;
            h.face_err = tets[t].ferr;
            owned.clear();
            for (uint32_t k = 0; k < tets[t].owned; ++k) owned.push_back(global(tets[t].head + k));
            h.points = uint32_t(owned.size());
        };
        {  // exact size: the brick's arrays are still alive, so no growth slack on top
            size_t bytes = 0;
            for (uint32_t t = 0; t < tets.size(); ++t)
                if (!tets[t].dead) hand_over(t), bytes += BrickMesh::record_size(h, owned.data());
            mesh.bytes.reserve(bytes);
        }
        for (uint32_t t = 0; t < tets.size(); ++t)
            if (!tets[t].dead) hand_over(t), mesh.append(h, owned.data());
    }
};

}  // namespace

size_t brick_working_bytes(const BrickBox& box, const std::vector<BrickMesh*>& input) {
    using D = BrickDecimator;
    size_t box_points = 1, cells = 1;
    for (int a = 0; a < 3; ++a)
        box_points *= size_t(box.hi[a] - box.lo[a] + 1), cells *= size_t(box.hi[a] - box.lo[a]);
    size_t tets = 0, owned = 0, vertices = 0;
    if (input.empty()) {
        tets = 5 * cells, vertices = box_points;
    } else {
        for (const BrickMesh* b : input) tets += b->tets, owned += b->points;
        vertices = tets / 4;  // about 5-6 tets per vertex in a decimated mesh; a margin
    }
    // Per tet: its record and back links; per point its record, and a copy in a block for
    // every point removed (twice, with the dead blocks); per vertex its state
    // (first corner, stamp, heap sequence, no-target cutoff) and a heap entry; per box
    // point a bit.
    return tets * (sizeof(D::TetRec) + 4 * sizeof(uint32_t)) + (vertices + 2 * (vertices + owned)) * sizeof(D::PointRec) +
           vertices * (3 * sizeof(uint32_t) + sizeof(float) + sizeof(Entry)) + box_points / 8 + box_points / 16;
}

BrickResult decimate_brick(const Volume& vol, const MtBuildOptions& opt, const BrickBox& box,
                           const std::vector<BrickMesh*>& input, NodeState& nodes, const BrickProgress& progress,
                           const std::atomic<bool>* spare_threads) {
    BrickResult r;
    BrickDecimator d(vol, opt, box, input, nodes, r);
    d.spare_threads = spare_threads;
    d.run(progress);
    r.mask_bit_count = d.mask_bit_count;
    return r;
}

}  // namespace tetlod::mt
