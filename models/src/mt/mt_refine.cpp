// MT selective refinement (normative: spec/mt-model.md §M5-§M7): top-down vertex splits
// from the base mesh. A node v may split when every current neighbour has a
// smaller label; then its star is its creation star, ordered canonically, and the
// stored mask says which tets go to the inserted point w. Blocked nodes first
// force the splits of the creators of the tets around them (max-heap on label),
// which is exactly the set of ancestors in the explicit DAG, so the result is the
// minimal closed set of splits whose front satisfies the query.
#include <algorithm>
#include <cmath>
#include <queue>
#include <string>

#include "../query/lod_query_region.hpp"
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
}  // namespace

struct MtRefiner {
    const MtModel& m;
    const LodQuery& q;
    mt::Grid grid;
    uint32_t n;
    detail::QueryBounds bounds;

    std::vector<std::array<uint32_t, 4>> tv;
    std::vector<uint32_t> tnext;
    std::vector<uint8_t> alive;
    std::vector<uint32_t> free_tets;
    std::vector<uint32_t> vhead, pos, label, wanted;
    std::priority_queue<std::pair<uint32_t, uint32_t>> heap;  // (label, grid point)
    MtExtractStats st;

    MtRefiner(const MtModel& model, const LodQuery& query)
        : m(model), q(query), grid(model.dims()), n(uint32_t(model.dims().count())),
          bounds(detail::query_bounds(query)) {}

    uint32_t current_update(uint32_t p) const {
        return m.csr_start_[p] + pos[p] - 1;
    }
    void set_node(uint32_t p, uint32_t npos) {
        pos[p] = npos;
        label[p] = npos == 0 ? 0 : m.updates_[m.csr_start_[p] + npos - 1].label;
    }
    void link_corner(uint32_t v, uint32_t c) {
        tnext[c] = vhead[v];
        vhead[v] = c;
    }
    uint32_t new_tet(const std::array<uint32_t, 4>& t) {
        uint32_t id;
        if (!free_tets.empty()) {
            id = free_tets.back();
            free_tets.pop_back();
            tv[id] = t;
            alive[id] = 1;
        } else {
            id = uint32_t(tv.size());
            if (tv.size() >= 8 * size_t(n) + 64) corrupt("too many tets");
            tv.push_back(t);
            alive.push_back(1);
            tnext.insert(tnext.end(), 4, kNil);
        }
        return id;
    }
    std::array<Pt, 4> pts_of(const std::array<uint32_t, 4>& t) const {
        return {grid.coord(t[0]), grid.coord(t[1]), grid.coord(t[2]), grid.coord(t[3])};
    }

    /// Creator (vertex of largest label) of a tet; kNil for a reference tet.
    uint32_t creator(const std::array<uint32_t, 4>& t) const {
        uint32_t best = t[0];
        bool tie = false;
        for (int i = 1; i < 4; ++i) {
            if (label[t[i]] > label[best]) best = t[i], tie = false;
            else if (label[t[i]] == label[best]) tie = true;
        }
        if (label[best] == 0) return kNil;
        if (tie) corrupt("two vertices of a tet share the largest label");
        return best;
    }

    double bound(const std::array<uint32_t, 4>& t, double err) const {
        if (!bounds.region) return bounds.in;  // spares the corners' coordinates
        return detail::query_bound(q, bounds, pts_of(t), [&](int i) { return m.field_.value(t[i]); }, err);
    }

    void check(uint32_t t) {
        ++st.visited_tets;
        const uint32_t c = creator(tv[t]);
        if (c == kNil) return;
        const double err = m.updates_[current_update(c)].error;
        if (err > bound(tv[t], err)) {
            wanted[c] = label[c];
            heap.push({label[c], c});
        }
    }

    std::vector<uint32_t> star, perm;
    std::vector<std::pair<int64_t, std::array<uint32_t, 3>>> keys;
    struct FaceUse {
        std::array<uint32_t, 2> ab;
        uint8_t wside;
        bool operator<(const FaceUse& o) const { return ab < o.ab || (ab == o.ab && wside < o.wside); }
    };
    std::vector<FaceUse> faces;
    std::vector<uint32_t> touched;

    void split(uint32_t s) {
        const uint32_t k = current_update(s);
        const MtUpdate& u = m.updates_[k];
        if (u.s != s) corrupt("survivor mismatch");
        const uint32_t w = u.w;
        if (vhead[w] != kNil) corrupt("inserted point already present");
        if (star.size() != u.star) corrupt("star size differs from the stored one");
        const Pt ps = grid.coord(s), pw = grid.coord(w);
        mt::star_order(star, s, ps, pw, grid, [&](uint32_t t) -> const std::array<uint32_t, 4>& { return tv[t]; },
                       perm, keys);
        std::vector<uint8_t> side(star.size());
        const uint64_t mask = m.mask_offset(k);
        for (uint32_t r = 0; r < perm.size(); ++r) side[perm[r]] = m.mask_bit(mask + r) ? 1 : 0;
        faces.clear();
        for (size_t i = 0; i < star.size(); ++i) {
            std::array<uint32_t, 3> o{};
            int c = 0;
            for (int j = 0; j < 4; ++j)
                if (tv[star[i]][j] != s) o[c++] = tv[star[i]][j];
            std::sort(o.begin(), o.end());
            faces.push_back({{o[0], o[1]}, side[i]});
            faces.push_back({{o[0], o[2]}, side[i]});
            faces.push_back({{o[1], o[2]}, side[i]});
        }
        std::sort(faces.begin(), faces.end());
        std::vector<std::array<uint32_t, 2>> edge_tets;
        for (size_t i = 0; i < faces.size();) {
            size_t j = i;
            while (j < faces.size() && faces[j].ab == faces[i].ab) ++j;
            if (j - i > 2) corrupt("non-manifold star");
            if (j - i == 2) {
                if (faces[i].wside != faces[i + 1].wside) edge_tets.push_back(faces[i].ab);
            } else if (faces[i].wside) {
                const auto& ab = faces[i].ab;
                if (mt::orient(ps, grid.coord(ab[0]), grid.coord(ab[1]), pw) != 0) edge_tets.push_back(ab);
            }
            i = j;
        }
        // Rewire: w-side tets move to w; chains of s and w are rebuilt.
        vhead[s] = kNil;
        touched.clear();
        for (size_t i = 0; i < star.size(); ++i) {
            const uint32_t t = star[i];
            int slot = 0;
            while (tv[t][slot] != s) ++slot;
            if (side[i]) {
                tv[t][slot] = w;
                const auto p = pts_of(tv[t]);
                if (mt::orient(p[0], p[1], p[2], p[3]) <= 0) corrupt("split inverts a tet");
                link_corner(w, 4 * t + slot);
            } else {
                link_corner(s, 4 * t + slot);
            }
            touched.push_back(t);
        }
        for (const auto& ab : edge_tets) {
            std::array<uint32_t, 4> t{s, w, ab[0], ab[1]};
            const int64_t o = mt::orient(ps, pw, grid.coord(ab[0]), grid.coord(ab[1]));
            if (o == 0) corrupt("flat edge tet");
            if (o < 0) std::swap(t[2], t[3]);
            const uint32_t id = new_tet(t);
            for (int j = 0; j < 4; ++j) link_corner(t[j], 4 * id + j);
            touched.push_back(id);
        }
        st.tets_removed += star.size();
        st.tets_inserted += star.size() + edge_tets.size();
        ++st.splits;
        if (wanted[s] != label[s]) ++st.forced_splits;
        set_node(s, pos[s] - 1);
        set_node(w, m.csr_start_[w + 1] - m.csr_start_[w]);
        if (label[w] >= u.label || label[s] >= u.label) corrupt("child label not below parent");
        for (uint32_t t : touched) check(t);
    }

    TetMesh run() {
        vhead.assign(n, kNil);
        pos.assign(n, 0);
        label.assign(n, 0);
        wanted.assign(n, 0);
        tv = m.base_;
        alive.assign(tv.size(), 1);
        tnext.assign(4 * tv.size(), kNil);
        for (uint32_t t = 0; t < tv.size(); ++t)
            for (int j = 0; j < 4; ++j) {
                const uint32_t v = tv[t][j];
                if (vhead[v] == kNil) set_node(v, m.csr_start_[v + 1] - m.csr_start_[v]);
                link_corner(v, 4 * t + j);
            }
        for (uint32_t t = 0; t < tv.size(); ++t) check(t);
        uint64_t pops = 0;
        const uint64_t max_pops = 64 * (uint64_t(m.updates_.size()) + 16) * 8;
        while (!heap.empty()) {
            if (++pops > max_pops) corrupt("refinement does not terminate");
            const auto [lab, p] = heap.top();
            heap.pop();
            if (vhead[p] == kNil || label[p] != lab || lab == 0) continue;
            star.clear();
            bool blocked = false;
            for (uint32_t c = vhead[p]; c != kNil; c = tnext[c]) {
                const uint32_t t = c >> 2;
                star.push_back(t);
                const uint32_t cr = creator(tv[t]);
                if (cr != p) {
                    if (cr == kNil || label[cr] <= lab) corrupt("blocked by a lower label");
                    heap.push({label[cr], cr});
                    blocked = true;
                }
            }
            if (blocked) {
                heap.push({lab, p});
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
        std::vector<uint32_t> vid(n, kNil);
        // Vertices in grid order (deterministic and cache friendly).
        for (uint32_t p = 0; p < n; ++p)
            if (vhead[p] != kNil) {
                vid[p] = uint32_t(mesh.points.size());
                mesh.points.push_back(grid.coord(p));
                mesh.values.push_back(m.field_.value(p));
            }
        for (uint32_t t = 0; t < tv.size(); ++t) {
            if (!alive[t]) continue;
            const auto& v = tv[t];
            mesh.tets.push_back({vid[v[0]], vid[v[1]], vid[v[2]], vid[v[3]]});
            const uint32_t c = creator(v);
            const double e = c == kNil ? 0.0 : m.updates_[current_update(c)].error;
            const uint32_t lv = c == kNil ? m.max_label_ : m.max_label_ - label[c];
            mesh.level.push_back(uint8_t(std::min<uint32_t>(lv, 255)));
            mesh.error.push_back(float(e));
            st.max_error = std::max(st.max_error, e);
        }
        return mesh;
    }
};

TetMesh MtModel::extract(const LodQuery& query, MtExtractStats* stats) const {
    detail::check_query(query);
    MtRefiner r(*this, query);
    TetMesh mesh = r.run();
    if (stats) *stats = r.st;
    return mesh;
}

}  // namespace tetlod
