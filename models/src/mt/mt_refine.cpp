// MT selective refinement (normative: spec/mt-model.md §M5-§M7): top-down vertex splits
// from the base mesh. A node v may split when every current neighbour has a
// smaller label; then its star is its creation star, ordered canonically, and the
// stored mask says which tets go to the inserted point w. Blocked nodes first
// force the splits of the creators of the tets around them (max-heap on label),
// which is exactly the set of ancestors in the explicit DAG, so the result is the
// minimal closed set of splits whose front satisfies the query.
#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>
#include <span>
#include <string>
#include <vector>

#include "../query/lod_query_region.hpp"
#include "mt_slot_map.hpp"
#include "tetlod/models/detail/mt_geometry.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

using mt::kNil;
using mt::Pt;

namespace {
[[noreturn]] void corrupt(const std::string& what) {
    throw Error(ErrorCode::CorruptData, "MT extraction: inconsistent model (" + what + ")");
}

/// extract's observer: reports nothing, compiled away.
struct NoObserver {
    static constexpr bool active = false;
};

/// extract_visiting's observer: one call per batch (the base mesh, then each split).
struct BatchObserver {
    static constexpr bool active = true;
    const std::function<void(std::span<const MtVisitedTet>)>& visit;
    std::vector<MtVisitedTet> batch;  // the batch being reported
    void operator()() const { visit(std::span<const MtVisitedTet>(batch)); }
};
}  // namespace

template <class Observer>
struct MtRefiner {
    /// A grid point that is a vertex of the current mesh. Only these have state, so a
    /// query's memory follows the mesh it visits, not the volume (docs/mt.md §6).
    struct Vertex {
        uint32_t grid;            // grid index
        uint32_t head = kNil;     // first corner (4 * tet + slot) of its corner chain
        uint32_t pos = 0;         // updates of the grid point applied to it, counted from the root
        uint32_t label = 0;       // label of its current node (0: a leaf)
        uint32_t wanted = 0;      // label at which a bound failure asked for its split
        // An entry of its current label is in the heap. Without it every failing tet of
        // a star pushed its creator again (a star has ~25 tets): most of an extraction's
        // time went to pushing and popping those duplicates, which change nothing (equal
        // keys, and the first one popped either splits the vertex, making the rest stale,
        // or puts it back).
        bool queued = false;
    };

    const MtModel& m;
    const LodQuery& q;
    mt::Grid grid;
    uint32_t n;
    detail::QueryBounds bounds;

    std::vector<Vertex> verts;
    mt::SlotMap slot_of;                       // grid index -> index in verts
    std::vector<std::array<uint32_t, 4>> tv;   // tets, grid indices (geometry, star order)
    std::vector<std::array<uint32_t, 4>> ts;   // the same tets, vertex slots (state)
    std::vector<uint32_t> tnext;               // per corner: next corner of the same vertex
    // (label, grid index, slot): ties between equal labels break by grid index.
    std::priority_queue<std::array<uint32_t, 3>> heap;
    MtExtractStats st;
    Observer observe;

    MtRefiner(const MtModel& model, const LodQuery& query, Observer observer)
        : m(model), q(query), grid(model.dims()), n(uint32_t(model.dims().count())),
          bounds(detail::query_bounds(query)), slot_of(4 * model.base_tets().size()), observe(observer) {}

    uint32_t updates_of(uint32_t g) const { return m.csr_start_[g + 1] - m.csr_start_[g]; }
    uint32_t current_update(uint32_t v) const { return m.csr_start_[verts[v].grid] + verts[v].pos - 1; }
    void set_node(uint32_t v, uint32_t npos) {
        Vertex& x = verts[v];
        x.pos = npos;
        x.label = npos == 0 ? 0 : m.splits_[m.csr_start_[x.grid] + npos - 1].label;
        x.queued = false;  // an entry of the old label is stale
    }
    uint32_t add_vertex(uint32_t g) {
        const uint32_t v = uint32_t(verts.size());
        verts.push_back(Vertex{g});
        slot_of.insert(g, v);
        set_node(v, updates_of(g));
        return v;
    }
    void link_corner(uint32_t v, uint32_t c) {
        tnext[c] = verts[v].head;
        verts[v].head = c;
    }
    uint32_t new_tet(const std::array<uint32_t, 4>& t, const std::array<uint32_t, 4>& slots) {
        if (tv.size() >= 8 * size_t(n) + 64) corrupt("too many tets");
        const uint32_t id = uint32_t(tv.size());
        tv.push_back(t);
        ts.push_back(slots);
        tnext.insert(tnext.end(), 4, kNil);
        return id;
    }
    std::array<Pt, 4> pts_of(const std::array<uint32_t, 4>& t) const {
        return {grid.coord(t[0]), grid.coord(t[1]), grid.coord(t[2]), grid.coord(t[3])};
    }

    /// Creator (vertex of largest label) of a tet given by slots; kNil for a reference tet.
    uint32_t creator(const std::array<uint32_t, 4>& t) const {
        uint32_t best = t[0];
        bool tie = false;
        for (int i = 1; i < 4; ++i) {
            if (verts[t[i]].label > verts[best].label) best = t[i], tie = false;
            else if (verts[t[i]].label == verts[best].label) tie = true;
        }
        if (verts[best].label == 0) return kNil;
        if (tie) corrupt("two vertices of a tet share the largest label");
        return best;
    }

    double bound(const std::array<uint32_t, 4>& t, double err) const {
        if (!bounds.region) return bounds.in;  // spares the corners' coordinates
        return detail::query_bound(q, bounds, pts_of(t), [&](int i) { return m.field_.value(t[i]); }, err);
    }

    /// Hands tets [ids] with their creators to the observer, as one batch (observed
    /// refinements only: instantiated under `if constexpr (Observer::active)`).
    template <class Ids>
    void report(const Ids& ids) {
        observe.batch.clear();
        for (const uint32_t t : ids) {
            MtVisitedTet x;
            x.tet = tv[t];
            if (const uint32_t c = creator(ts[t]); c != kNil) {
                x.creator = verts[c].grid;
                x.update = current_update(c);
            }
            observe.batch.push_back(x);
        }
        observe();
    }

    void want_split(uint32_t v) {
        if (verts[v].queued) return;
        verts[v].queued = true;
        heap.push({verts[v].label, verts[v].grid, v});
    }

    void check(uint32_t t) {
        ++st.visited_tets;
        const uint32_t c = creator(ts[t]);
        if (c == kNil) return;
        const double err = m.splits_[current_update(c)].error;
        // Within both bounds the region does not matter: no box or value test (as the HT).
        if (err <= bounds.min()) return;
        if (err > bound(tv[t], err)) {
            verts[c].wanted = verts[c].label;
            want_split(c);
        }
    }

    std::vector<uint32_t> star, perm;
    std::vector<mt::StarKey> keys;
    // A star tet's face through s, as its other two corners a < b in one 64-bit key
    // (a in the high half: the key order is the (a, b) order). Faces are matched in a
    // small open-addressing table: sorting the star's ~75 faces to pair them up was
    // 15 % of an extraction's time.
    static uint64_t face_key(uint32_t a, uint32_t b) { return (uint64_t(a) << 32) | b; }
    struct FaceSlot {
        uint64_t ab = 0;
        std::array<uint32_t, 2> slots{};  // the vertex slots of a and b
        uint8_t uses = 0;   // 0: empty; 1 or 2 star tets (3+: not a manifold)
        uint8_t wside = 0;  // the first tet's side
        uint8_t mixed = 0;  // two tets on different sides
    };
    std::vector<FaceSlot> face_table;  // size a power of two, at least twice the faces
    std::vector<uint32_t> face_used;   // slots filled, in insertion order
    void add_face(uint64_t ab, uint32_t sa, uint32_t sb, uint8_t wside) {
        const size_t mask = face_table.size() - 1;
        for (size_t i = size_t((ab * 0x9E3779B97F4A7C15ull) >> 40) & mask;; i = (i + 1) & mask) {
            FaceSlot& f = face_table[i];
            if (f.uses == 0) {
                f = FaceSlot{ab, {sa, sb}, 1, wside, 0};
                face_used.push_back(uint32_t(i));
                return;
            }
            if (f.ab == ab) {
                if (++f.uses > 2) corrupt("non-manifold star");
                f.mixed = f.wside != wside;
                return;
            }
        }
    }
    std::vector<uint8_t> side;                         // per star tet: goes to w
    struct EdgeTet {  // a new tet (s, w, a, b)
        uint64_t ab;                      // face_key(a, b)
        std::array<uint32_t, 2> slots;    // of a and b
    };
    std::vector<EdgeTet> edge_tets;
    std::vector<uint32_t> touched;

    void split(uint32_t sv) {
        const uint32_t s = verts[sv].grid;
        const uint32_t k = current_update(sv);
        const MtSplit& u = m.splits_[k];
        if (k < m.csr_start_[s] || k >= m.csr_start_[s + 1]) corrupt("survivor mismatch");
        const uint32_t w = u.w;
        if (slot_of.find(w) != mt::SlotMap::kAbsent) corrupt("inserted point already present");
        if (star.size() != u.star) corrupt("star size differs from the stored one");
        const Pt ps = grid.coord(s), pw = grid.coord(w);
        mt::star_order(star, s, ps, pw, [&](uint32_t v) { return grid.coord(v); }, [&](uint32_t t) -> const std::array<uint32_t, 4>& { return tv[t]; },
                       perm, keys);
        side.assign(star.size(), 0);
        const uint64_t mask = m.mask_offset(k);
        for (uint32_t r = 0; r < perm.size(); ++r) side[perm[r]] = m.mask_bit(mask + r) ? 1 : 0;
        size_t capacity = 64;
        while (capacity < 6 * star.size()) capacity *= 2;
        if (face_table.size() < capacity) face_table.assign(capacity, FaceSlot{});
        face_used.clear();
        for (size_t i = 0; i < star.size(); ++i) {
            std::array<uint32_t, 3> o{}, os{};  // the corners other than s: grid indices, slots
            int c = 0;
            for (int j = 0; j < 4; ++j)
                if (tv[star[i]][j] != s) o[c] = tv[star[i]][j], os[c++] = ts[star[i]][j];
            auto order = [&](int a, int b) {
                if (o[a] > o[b]) std::swap(o[a], o[b]), std::swap(os[a], os[b]);
            };
            order(0, 1), order(1, 2), order(0, 1);
            add_face(face_key(o[0], o[1]), os[0], os[1], side[i]);
            add_face(face_key(o[0], o[2]), os[0], os[2], side[i]);
            add_face(face_key(o[1], o[2]), os[1], os[2], side[i]);
        }
        // New tets (s, w, a, b): on faces shared by the two sides, and on boundary faces
        // of w's side unless flat; in (a, b) order (the order of the tets created).
        edge_tets.clear();
        for (const uint32_t i : face_used) {
            FaceSlot& f = face_table[i];
            const uint64_t ab = f.ab;
            if (f.uses == 2 ? f.mixed != 0
                            : f.wside && mt::orient(ps, grid.coord(uint32_t(ab >> 32)), grid.coord(uint32_t(ab)), pw) != 0)
                edge_tets.push_back({ab, f.slots});
            f = FaceSlot{};
        }
        std::sort(edge_tets.begin(), edge_tets.end(),
                  [](const EdgeTet& x, const EdgeTet& y) { return x.ab < y.ab; });
        // Rewire: w-side tets move to w; chains of s and w are rebuilt.
        const uint32_t wv = add_vertex(w);
        verts[sv].head = kNil;
        touched.clear();
        for (size_t i = 0; i < star.size(); ++i) {
            const uint32_t t = star[i];
            int slot = 0;
            while (tv[t][slot] != s) ++slot;
            if (side[i]) {
                tv[t][slot] = w;
                ts[t][slot] = wv;
                const auto p = pts_of(tv[t]);
                if (mt::orient(p[0], p[1], p[2], p[3]) <= 0) corrupt("split inverts a tet");
                link_corner(wv, 4 * t + slot);
            } else {
                link_corner(sv, 4 * t + slot);
            }
            touched.push_back(t);
        }
        for (const EdgeTet& e : edge_tets) {
            const uint32_t a = uint32_t(e.ab >> 32), b = uint32_t(e.ab);
            std::array<uint32_t, 4> t{s, w, a, b};
            std::array<uint32_t, 4> slots{sv, wv, e.slots[0], e.slots[1]};
            const int64_t o = mt::orient(ps, pw, grid.coord(a), grid.coord(b));
            if (o == 0) corrupt("flat edge tet");
            if (o < 0) std::swap(t[2], t[3]), std::swap(slots[2], slots[3]);
            const uint32_t id = new_tet(t, slots);
            for (int j = 0; j < 4; ++j) link_corner(slots[j], 4 * id + j);
            touched.push_back(id);
        }
        st.tets_removed += star.size();
        st.tets_inserted += star.size() + edge_tets.size();
        ++st.splits;
        if (verts[sv].wanted != verts[sv].label) ++st.forced_splits;
        set_node(sv, verts[sv].pos - 1);
        if (verts[wv].label >= u.label || verts[sv].label >= u.label) corrupt("child label not below parent");
        for (uint32_t t : touched) check(t);
        if constexpr (Observer::active) report(touched);
    }

    TetMesh run() {
        tv = m.base_;
        ts.resize(tv.size());
        tnext.assign(4 * tv.size(), kNil);
        for (uint32_t t = 0; t < tv.size(); ++t)
            for (int j = 0; j < 4; ++j) {
                const uint32_t g = tv[t][j];
                uint32_t v = slot_of.find(g);
                if (v == mt::SlotMap::kAbsent) v = add_vertex(g);
                ts[t][j] = v;
                link_corner(v, 4 * t + j);
            }
        for (uint32_t t = 0; t < tv.size(); ++t) check(t);
        if constexpr (Observer::active) {
            std::vector<uint32_t> all(tv.size());
            for (uint32_t t = 0; t < all.size(); ++t) all[t] = t;
            report(all);
        }
        uint64_t pops = 0;
        const uint64_t max_pops = 64 * (uint64_t(m.splits_.size()) + 16) * 8;
        while (!heap.empty()) {
            if (++pops > max_pops) corrupt("refinement does not terminate");
            const auto [lab, g, p] = heap.top();
            heap.pop();
            if (verts[p].label == lab) verts[p].queued = false;  // this was its entry
            if (verts[p].head == kNil || verts[p].label != lab || lab == 0) continue;
            star.clear();
            bool blocked = false;
            for (uint32_t c = verts[p].head; c != kNil; c = tnext[c]) {
                const uint32_t t = c >> 2;
                // The split reads the tet's grid indices next (star_order): ask for them
                // now, so their misses overlap the walk's instead of following it.
                __builtin_prefetch(&tv[t]);
                star.push_back(t);
                const uint32_t cr = creator(ts[t]);
                if (cr != p) {
                    if (cr == kNil || verts[cr].label <= lab) corrupt("blocked by a lower label");
                    want_split(cr);
                    blocked = true;
                }
            }
            if (blocked) {
                want_split(p);
                continue;
            }
            split(p);
        }
        return output();
    }

    TetMesh output() {
        TetMesh mesh;
        mesh.geometry.spacing = m.field_.spacing;
        mesh.geometry.origin = m.field_.origin;
        mesh.field_name = m.field_.field_name;
        mesh.value_type = m.field_.type;
        // Vertices in grid order (deterministic and cache friendly). A vertex left
        // without tets (only in an inconsistent model) is not output.
        std::vector<uint32_t> by_grid;
        by_grid.reserve(verts.size());
        for (uint32_t v = 0; v < verts.size(); ++v)
            if (verts[v].head != kNil) by_grid.push_back(v);
        std::sort(by_grid.begin(), by_grid.end(),
                  [&](uint32_t a, uint32_t b) { return verts[a].grid < verts[b].grid; });
        std::vector<uint32_t> vid(verts.size(), kNil);
        mesh.points.reserve(by_grid.size());
        mesh.values.reserve(by_grid.size());
        for (uint32_t v : by_grid) {
            vid[v] = uint32_t(mesh.points.size());
            mesh.points.push_back(grid.coord(verts[v].grid));
            mesh.values.push_back(m.field_.value(verts[v].grid));
        }
        mesh.tets.reserve(tv.size());
        mesh.level.reserve(tv.size());
        mesh.error.reserve(tv.size());
        for (uint32_t t = 0; t < tv.size(); ++t) {
            const auto& v = ts[t];
            mesh.tets.push_back({vid[v[0]], vid[v[1]], vid[v[2]], vid[v[3]]});
            const uint32_t c = creator(v);
            // A reference tet's grid points are its vertices: no error but the field's own.
            const double e = c == kNil ? double(m.field_error_bound_) : m.splits_[current_update(c)].error;
            const uint32_t lv = c == kNil ? m.max_label_ : m.max_label_ - verts[c].label;
            mesh.level.push_back(uint8_t(std::min<uint32_t>(lv, 255)));
            mesh.error.push_back(float(e));
            st.max_error = std::max(st.max_error, e);
        }
        return mesh;
    }
};

TetMesh MtModel::extract(const LodQuery& query, MtExtractStats* stats) const {
    detail::check_query(query);
    MtRefiner<NoObserver> r(*this, query, NoObserver{});
    TetMesh mesh = r.run();
    if (stats) *stats = r.st;
    return mesh;
}

TetMesh MtModel::extract_visiting(const LodQuery& query,
                                  const std::function<void(std::span<const MtVisitedTet>)>& visit,
                                  MtExtractStats* stats) const {
    detail::check_query(query);
    if (!visit) throw Error(ErrorCode::InvalidArgument, "MT extract_visiting: no visitor");
    MtRefiner<BatchObserver> r(*this, query, BatchObserver{visit, {}});
    TetMesh mesh = r.run();
    if (stats) *stats = r.st;
    return mesh;
}

}  // namespace tetlod
