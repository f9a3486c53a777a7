// MT builder and selective refinement: every result is checked by the independent
// brute-force checker of tests/support (conformity, volume, the bound at every grid
// point), compared with an explicit-DAG oracle that applies the recorded node-space
// tet history (spec/mt-model.md §M6), and rebuilt for determinism.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <queue>
#include <cstring>
#include <set>

#include "mt_test_util.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::test {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Case {
    Dims dims;
    ValueType type;
    Field field;
    int brick_cells = MtBuildOptions{}.brick_cells;  // bricked build (docs/mt.md §2)
};

std::string case_str(const Case& c) {
    return dims_str(c.dims) + " " + value_type_name(c.type) + " " + field_name(c.field) + " bricks " +
           std::to_string(c.brick_cells);
}

const std::vector<Case>& small_cases() {
    static const std::vector<Case> cases = {
        {{2, 2, 2}, ValueType::U8, Field::Smooth},    {{2, 3, 2}, ValueType::F32, Field::Noisy},
        {{5, 3, 7}, ValueType::U8, Field::Noisy},     {{5, 3, 7}, ValueType::I16, Field::Smooth},
        {{9, 9, 9}, ValueType::U8, Field::Plateau},   {{9, 9, 9}, ValueType::F32, Field::Smooth},
        {{12, 9, 7}, ValueType::I16, Field::Noisy},   {{12, 9, 7}, ValueType::U8, Field::Smooth},
        {{3, 11, 4}, ValueType::U8, Field::Constant}, {{17, 17, 17}, ValueType::U8, Field::Smooth},
        {{17, 17, 17}, ValueType::I16, Field::Plateau},
        // Bricked builds: bricks smaller than the volume along every axis, sizes that do
        // not divide the cells (partial bricks at the far faces), several merge passes.
        {{7, 6, 5}, ValueType::U8, Field::Noisy, 2},       {{12, 9, 7}, ValueType::I16, Field::Smooth, 3},
        {{11, 10, 9}, ValueType::F32, Field::Noisy, 4},    {{9, 9, 9}, ValueType::U8, Field::Constant, 1},
        {{17, 13, 15}, ValueType::U8, Field::Plateau, 5},  {{6, 14, 5}, ValueType::I16, Field::Noisy, 3},
        // Smooth enough that the early passes coarsen across the later passes' faces:
        // tets crossing a face are carried over a pass (mt_brick_passes.hpp).
        {{15, 13, 11}, ValueType::U8, Field::Smooth, 2},   {{13, 16, 12}, ValueType::F32, Field::Smooth, 3},
    };
    return cases;
}

/// Builds (and caches) the model of a case, with the explicit history.
const MtModel& model_of(const Case& c, const Volume** vol_out = nullptr) {
    struct Entry {
        Volume vol;
        std::unique_ptr<MtModel> model;
    };
    static std::map<std::string, Entry> cache;
    const std::string key = case_str(c);
    auto it = cache.find(key);
    if (it == cache.end()) {
        Entry e;
        e.vol = make_volume(c.dims, c.type, c.field, 7);
        MtBuildOptions opt;
        opt.record_history = c.dims.count() <= 17 * 17 * 17;
        opt.brick_cells = c.brick_cells;
        e.model = std::make_unique<MtModel>(MtModel::build(e.vol, opt));
        it = cache.emplace(key, std::move(e)).first;
    }
    if (vol_out) *vol_out = &it->second.vol;
    return *it->second.model;
}

std::vector<LodQuery> queries_for(const Volume& v) {
    const auto r = v.range();
    const double span = std::max(r[1] - r[0], 1e-9);
    std::vector<LodQuery> qs;
    for (double f : {-1.0, 0.0, 0.01, 0.05, 0.2, 1.0}) {
        LodQuery q;
        q.error_in = f < 0 ? -1.0 : f * span;
        qs.push_back(q);
    }
    LodQuery coarse;  // +inf: the base mesh
    qs.push_back(coarse);
    const int64_t X = v.dims.x - 1, Y = v.dims.y - 1, Z = v.dims.z - 1;
    for (int i = 0; i < 3; ++i) {
        LodQuery q;
        q.error_in = i == 0 ? 0.0 : 0.02 * span;
        q.error_out = i == 2 ? 0.0 : kInf;  // box may also be the coarse part
        if (i == 2) q.error_in = 0.3 * span;
        q.box = std::array<int64_t, 6>{X / 4, Y / 3 * (i % 2), 0, X / 2 + i, Y, Z / 2};
        qs.push_back(q);
    }
    {
        LodQuery q;  // box sticking out of the data
        q.error_in = 0.0, q.error_out = 0.5 * span;
        q.box = std::array<int64_t, 6>{X / 2, -5, Z / 2, X + 10, Y / 2, Z + 3};
        qs.push_back(q);
    }
    for (int i = 0; i < 2; ++i) {
        LodQuery q;
        q.error_in = i == 0 ? 0.0 : 0.03 * span;
        q.error_out = 0.4 * span;
        q.isovalues = {r[0] + 0.5 * span};
        if (i == 1) q.isovalues.push_back(r[0] + 0.25 * span);
        qs.push_back(q);
    }
    {
        LodQuery q;  // box AND isovalue
        q.error_in = 0.0, q.error_out = kInf;
        q.box = std::array<int64_t, 6>{0, 0, 0, X / 2, Y / 2, Z};
        q.isovalues = {r[0] + 0.4 * span};
        qs.push_back(q);
    }
    for (int i = 0; i < 2; ++i) {
        LodQuery q;  // a sphere (a registered region), alone and AND-ed with an isovalue
        const int64_t radius = std::max<int64_t>(1, std::max({X, Y, Z}) / 3);
        q.regions = {sphere_region({X / 2, Y / 3, Z / 2}, radius)};
        q.error_in = 0.0, q.error_out = i == 0 ? kInf : 0.3 * span;
        if (i == 1) q.isovalues = {r[0] + 0.5 * span};
        qs.push_back(q);
    }
    LodQuery full;
    full.full = true;
    qs.push_back(full);
    return qs;
}

using KeyTet = std::array<std::array<int32_t, 3>, 4>;
KeyTet key_of(std::array<std::array<int32_t, 3>, 4> t) {
    std::sort(t.begin(), t.end());
    return t;
}

/// Explicit-DAG oracle (spec/mt-model.md §M6, Magillo's MT_IncludeNode): tets are node tuples;
/// split k removes after[k] and creates before[k]. A front tet failing its bound
/// includes the split that removes it, ancestors first.
std::set<KeyTet> oracle_extract(const MtModel& m, const Volume& vol, const LodQuery& q) {
    const MtHistory& h = *m.history();
    const uint32_t n = uint32_t(vol.count());
    const auto& ups = m.updates();
    auto grid_of = [&](uint32_t node) { return node < n ? node : m.survivor(h.update_of_node[node - n]); };
    auto coord = [&](uint32_t g) {
        return std::array<int32_t, 3>{int32_t(g % vol.dims.x), int32_t(g / vol.dims.x % vol.dims.y),
                                      int32_t(g / (vol.dims.x * vol.dims.y))};
    };
    using NT = std::array<uint32_t, 4>;
    auto sorted = [](NT t) {
        std::sort(t.begin(), t.end());
        return t;
    };
    constexpr uint32_t kRoot = 0xFFFFFFFFu;
    std::map<NT, uint32_t> remover, creator;
    for (uint32_t k = 0; k < h.after.size(); ++k) {
        for (const auto& t : h.after[k]) remover[sorted(t)] = k;
        for (const auto& t : h.before[k]) creator[sorted(t)] = k;
    }
    for (const auto& t : h.base) creator[sorted(t)] = kRoot;
    std::set<NT> front;
    for (const auto& t : h.base) front.insert(sorted(t));
    std::vector<uint8_t> done(ups.size(), 0);
    auto pts = [&](const NT& t) {
        TetPts p;
        for (int i = 0; i < 4; ++i) p[i] = coord(grid_of(t[i]));
        return p;
    };
    const double eps_in = q.full ? -1.0 : q.error_in;
    const double eps_out = q.full ? -1.0 : (q.has_region() ? q.error_out : q.error_in);
    auto fails = [&](const NT& t, uint32_t& k) {
        auto it = remover.find(t);
        if (it == remover.end()) return false;
        k = it->second;
        const double err = ups[h.update_of_node[k]].error;
        bool in = true;
        if (!q.full && q.has_region()) {
            const TetPts p = pts(t);
            if (q.box) {
                auto& b = *q.box;
                in = tet_meets_box(p, {int32_t(b[0]), int32_t(b[1]), int32_t(b[2])},
                                   {int32_t(b[3]), int32_t(b[4]), int32_t(b[5])});
            }
            in = in && oracle_meets_regions(q, p);
            if (in && !q.isovalues.empty()) {
                double lo = kInf, hi = -kInf;
                for (int i = 0; i < 4; ++i) {
                    const double f = vol.value(p[i][0], p[i][1], p[i][2]);
                    lo = std::min(lo, f), hi = std::max(hi, f);
                }
                bool hit = false;
                for (double v : q.isovalues) hit = hit || (lo - err <= v && v <= hi + err);
                in = hit;
            }
        }
        return err > (in ? eps_in : eps_out);
    };
    std::function<void(uint32_t)> include = [&](uint32_t k) {
        if (done[k]) return;
        for (const auto& t : h.after[k]) {
            const uint32_t c = creator.at(sorted(t));
            if (c != kRoot) include(c);
        }
        done[k] = 1;
        for (const auto& t : h.after[k]) {
            const bool erased = front.erase(sorted(t)) == 1;
            if (!erased) ADD_FAILURE() << "oracle: update " << k << " removes a tet not in the front";
        }
        for (const auto& t : h.before[k]) front.insert(sorted(t));
    };
    for (bool changed = true; changed;) {
        changed = false;
        std::vector<uint32_t> todo;
        for (const auto& t : front) {
            uint32_t k;
            if (fails(t, k)) todo.push_back(k);
        }
        for (uint32_t k : todo)
            if (!done[k]) include(k), changed = true;
    }
    std::set<KeyTet> out;
    for (const auto& t : front) out.insert(key_of(pts(t)));
    return out;
}

std::set<KeyTet> mesh_keys(const TetMesh& mesh) {
    std::set<KeyTet> out;
    for (const auto& t : mesh.tets)
        out.insert(key_of({mesh.points[t[0]], mesh.points[t[1]], mesh.points[t[2]], mesh.points[t[3]]}));
    return out;
}

TEST(MtBuild, FullGivesTheReferenceMesh) {
    for (const Case& c : small_cases()) {
        SCOPED_TRACE(case_str(c));
        const Volume* vol;
        const MtModel& m = model_of(c, &vol);
        LodQuery q;
        q.full = true;
        MtExtractStats st;
        const TetMesh mesh = m.extract(q, &st);
        EXPECT_EQ(int64_t(mesh.tet_count()), 5 * cells(c.dims));
        EXPECT_EQ(int64_t(mesh.vertex_count()), c.dims.count());
        EXPECT_EQ(st.splits, m.updates().size());
        EXPECT_TRUE(mesh_ok(*vol, mesh, mt_check_options(q, *vol)));
    }
}

// spec/mt-model.md §M2, written here from the text (not from the library's
// reference_tets): the full query gives exactly that mesh, positively oriented.
TEST(MtSpec, FullMeshIsTheSpecReferenceMesh) {
    for (const Case& c : small_cases()) {
        SCOPED_TRACE(case_str(c));
        const MtModel& m = model_of(c);
        LodQuery q;
        q.full = true;
        const TetMesh mesh = m.extract(q);
        for (const auto& t : mesh.tets) {
            std::array<std::array<int64_t, 3>, 4> p;
            for (int i = 0; i < 4; ++i)
                for (int a = 0; a < 3; ++a) p[i][a] = mesh.points[t[i]][a];
            std::array<std::array<int64_t, 3>, 3> e;
            for (int i = 0; i < 3; ++i)
                for (int a = 0; a < 3; ++a) e[i][a] = p[i + 1][a] - p[0][a];
            const int64_t det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                                e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                                e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
            EXPECT_GT(det, 0);
        }
        std::set<KeyTet> want;
        const Dims& d = c.dims;
        for (int32_t k = 0; k + 1 < d.z; ++k)
            for (int32_t j = 0; j + 1 < d.y; ++j)
                for (int32_t i = 0; i + 1 < d.x; ++i) {
                    auto corner = [&](int cc) {
                        return std::array<int32_t, 3>{i + (cc & 1), j + (cc >> 1 & 1), k + (cc >> 2)};
                    };
                    auto even = [&](int cc) {
                        const auto p = corner(cc);
                        return (p[0] + p[1] + p[2]) % 2 == 0;
                    };
                    std::vector<std::array<int32_t, 3>> central;
                    for (int cc = 0; cc < 8; ++cc)
                        if (even(cc)) central.push_back(corner(cc));
                    ASSERT_EQ(central.size(), 4u);
                    want.insert(key_of({central[0], central[1], central[2], central[3]}));
                    for (int cc = 0; cc < 8; ++cc)
                        if (!even(cc)) want.insert(key_of({corner(cc), corner(cc ^ 1), corner(cc ^ 2), corner(cc ^ 4)}));
                }
        EXPECT_EQ(mesh_keys(mesh), want);
    }
}

namespace {

/// An MT extractor written from spec/mt-model.md §M3-§M7 alone (no box queries):
/// plain vectors and linear star scans, to check that the text determines the result.
struct SpecExtractor {
    using P = std::array<int64_t, 3>;
    const MtModel& m;
    const LodQuery& q;
    int64_t X, Y;
    std::vector<std::vector<uint32_t>> U;  // U_p: update indices with s = p, by label
    std::vector<int64_t> pos;              // -1: not in the mesh
    std::vector<std::array<uint32_t, 4>> tets;

    SpecExtractor(const MtModel& model, const LodQuery& query)
        : m(model), q(query), X(model.dims().x), Y(model.dims().y) {
        const size_t n = size_t(model.dims().count());
        U.resize(n);
        for (uint32_t k = 0; k < m.updates().size(); ++k) U[m.survivor(k)].push_back(k);
        for (auto& l : U)
            std::sort(l.begin(), l.end(), [&](uint32_t a, uint32_t b) { return m.updates()[a].label < m.updates()[b].label; });
        pos.assign(n, -1);
    }
    P at(uint32_t i) const { return {int64_t(i) % X, int64_t(i) / X % Y, int64_t(i) / X / Y}; }
    static int64_t orient(const P& a, const P& b, const P& c, const P& d) {
        const P u{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v{c[0] - a[0], c[1] - a[1], c[2] - a[2]},
            w{d[0] - a[0], d[1] - a[1], d[2] - a[2]};
        return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
               u[2] * (v[0] * w[1] - v[1] * w[0]);
    }
    uint32_t label(uint32_t p) const { return pos[p] <= 0 ? 0 : m.updates()[U[p][pos[p] - 1]].label; }
    const MtSplit& current(uint32_t p) const { return m.updates()[U[p][pos[p] - 1]]; }
    int64_t creator(const std::array<uint32_t, 4>& t) const {
        uint32_t best = t[0];
        for (uint32_t v : t)
            if (label(v) > label(best)) best = v;
        if (label(best) == 0) return -1;
        int same = 0;
        for (uint32_t v : t) same += label(v) == label(best);
        EXPECT_EQ(same, 1);
        return best;
    }
    bool fails(const std::array<uint32_t, 4>& t) const {
        const int64_t c = creator(t);
        if (c < 0) return false;
        const double err = current(uint32_t(c)).error;
        const double ein = q.full ? -1.0 : q.error_in;
        const double eout = q.full ? -1.0 : (q.has_region() ? q.error_out : q.error_in);
        double b = ein;
        if (!q.full && !q.isovalues.empty()) {
            double lo = m.field().value(t[0]), hi = lo;
            for (uint32_t v : t) lo = std::min(lo, m.field().value(v)), hi = std::max(hi, m.field().value(v));
            bool in = false;
            for (double iso : q.isovalues) in = in || (lo - err <= iso && iso <= hi + err);
            b = in ? ein : eout;
        }
        return err > b;
    }
    std::vector<uint32_t> star(uint32_t s) const {
        std::vector<uint32_t> out;
        for (uint32_t i = 0; i < tets.size(); ++i)
            if (std::find(tets[i].begin(), tets[i].end(), s) != tets[i].end()) out.push_back(i);
        return out;
    }
    std::vector<uint32_t> split(uint32_t s) {  // §M5; returns the tets it produced
        const MtSplit& u = current(s);
        const uint32_t w = u.w;
        EXPECT_EQ(pos[w], -1);
        std::vector<uint32_t> st = star(s);
        EXPECT_EQ(st.size(), size_t(u.star));
        const P ps = at(s), pw = at(w);
        auto key = [&](uint32_t i) {
            int64_t dot = 0;
            std::array<uint32_t, 3> f{};
            int nf = 0;
            for (uint32_t v : tets[i]) {
                const P p = at(v);
                for (int a = 0; a < 3; ++a) dot += (p[a] - ps[a]) * (pw[a] - ps[a]);
                if (v != s) f[nf++] = v;
            }
            std::sort(f.begin(), f.end());
            return std::make_pair(-dot, f);
        };
        std::sort(st.begin(), st.end(), [&](uint32_t a, uint32_t b) { return key(a) < key(b); });
        std::map<std::pair<uint32_t, uint32_t>, std::vector<bool>> sides;  // face (s,a,b) -> sides
        std::vector<bool> side(st.size());
        for (size_t r = 0; r < st.size(); ++r) {
            side[r] = m.mask_bit(m.mask_offset(U[s][pos[s] - 1]) + r);
            std::vector<uint32_t> o;
            for (uint32_t v : tets[st[r]])
                if (v != s) o.push_back(v);
            std::sort(o.begin(), o.end());
            static constexpr int kE[3][2] = {{0, 1}, {0, 2}, {1, 2}};
            for (const auto& e : kE) sides[{o[e[0]], o[e[1]]}].push_back(side[r]);
        }
        std::vector<uint32_t> made = st;
        for (size_t r = 0; r < st.size(); ++r)
            if (side[r]) {
                for (uint32_t& v : tets[st[r]])
                    if (v == s) v = w;
                const auto& t = tets[st[r]];
                EXPECT_GT(orient(at(t[0]), at(t[1]), at(t[2]), at(t[3])), 0);
            }
        for (const auto& [ab, sd] : sides) {
            EXPECT_LE(sd.size(), 2u);
            const bool edge = sd.size() == 2 ? sd[0] != sd[1]
                                             : sd[0] && orient(ps, at(ab.first), at(ab.second), pw) != 0;
            if (!edge) continue;
            const int64_t o = orient(ps, pw, at(ab.first), at(ab.second));
            EXPECT_NE(o, 0);
            tets.push_back(o > 0 ? std::array<uint32_t, 4>{s, w, ab.first, ab.second}
                                 : std::array<uint32_t, 4>{s, w, ab.second, ab.first});
            made.push_back(uint32_t(tets.size() - 1));
        }
        pos[s] -= 1;
        pos[w] = int64_t(U[w].size());
        EXPECT_LT(label(w), u.label);
        EXPECT_LT(label(s), u.label);
        return made;
    }
    std::set<KeyTet> run() {  // §M7
        tets = m.base_tets();
        for (const auto& t : tets)
            for (uint32_t v : t) pos[v] = int64_t(U[v].size());
        std::priority_queue<std::pair<uint32_t, uint32_t>> heap;
        auto check = [&](uint32_t i) {
            if (fails(tets[i])) {
                const uint32_t c = uint32_t(creator(tets[i]));
                heap.push({label(c), c});
            }
        };
        for (uint32_t i = 0; i < tets.size(); ++i) check(i);
        while (!heap.empty()) {
            const auto [l, p] = heap.top();
            heap.pop();
            if (pos[p] < 0 || label(p) != l || l == 0) continue;
            bool blocked = false;
            for (uint32_t i : star(p)) {
                const int64_t c = creator(tets[i]);
                if (c != int64_t(p)) {
                    EXPECT_GT(label(uint32_t(c)), l);
                    heap.push({label(uint32_t(c)), uint32_t(c)});
                    blocked = true;
                }
            }
            if (blocked) {
                heap.push({l, p});
                continue;
            }
            for (uint32_t i : split(p)) check(i);
        }
        std::set<KeyTet> out;
        for (const auto& t : tets) {
            KeyTet k;
            for (int i = 0; i < 4; ++i) {
                const P p = at(t[i]);
                k[i] = {int32_t(p[0]), int32_t(p[1]), int32_t(p[2])};
            }
            out.insert(key_of(k));
        }
        return out;
    }
};

}  // namespace

TEST(MtSpec, AnExtractorWrittenFromTheSpecGivesTheSameMeshes) {
    for (const Case& c : small_cases()) {
        SCOPED_TRACE(case_str(c));
        const Volume* vol;
        const MtModel& m = model_of(c, &vol);
        int run = 0;
        for (const LodQuery& q : queries_for(*vol)) {
            // the spec's box test and further regions are checked by the independent checker
            if (q.box || !q.regions.empty()) continue;
            SCOPED_TRACE(run++);
            SpecExtractor spec(m, q);
            EXPECT_EQ(spec.run(), mesh_keys(m.extract(q)));
        }
    }
}

TEST(MtBuild, DecimatesFar) {
    for (const Case& c : small_cases()) {
        SCOPED_TRACE(case_str(c));
        const MtModel& m = model_of(c);
        // Updates + base vertices = grid points; the base mesh is small for smooth data.
        std::set<uint32_t> base_vertices;
        for (const auto& t : m.base_tets()) base_vertices.insert(t.begin(), t.end());
        EXPECT_EQ(m.updates().size() + base_vertices.size(), size_t(c.dims.count()));
        if (c.field == Field::Constant || c.dims.count() <= 8) {
            EXPECT_LE(m.base_tets().size(), 12u);
        }
    }
}

TEST(MtExtract, QueriesPassTheIndependentChecker) {
    for (const Case& c : small_cases()) {
        const Volume* vol;
        const MtModel& m = model_of(c, &vol);
        for (const LodQuery& q : queries_for(*vol)) {
            SCOPED_TRACE(case_str(c) + " " + query_str(q));
            const TetMesh mesh = m.extract(q);
            EXPECT_TRUE(mesh_ok(*vol, mesh, mt_check_options(q, *vol)));
            // Every stored bound is honoured by the tet (exact recomputation).
            for (size_t i = 0; i < mesh.tet_count(); i += 7) {
                const double e = exact_tet_error(*vol, tet_points(mesh, i));
                EXPECT_LE(e, double(mesh.error[i]) + float_tolerance(*vol)) << "tet " << i;
            }
        }
    }
}

TEST(MtExtract, MatchesTheExplicitDagOracle) {
    // Counted, so that the test fails if it ever compares nothing (a model
    // built without its history, an empty query list, an empty oracle mesh).
    std::size_t models = 0, compared = 0, nonempty = 0;
    for (const Case& c : small_cases()) {
        const Volume* vol;
        const MtModel& m = model_of(c, &vol);
        ASSERT_NE(m.history(), nullptr) << case_str(c) << ": built without the explicit history";
        ++models;
        for (const LodQuery& q : queries_for(*vol)) {
            SCOPED_TRACE(case_str(c) + " " + query_str(q));
            const auto expect = oracle_extract(m, *vol, q);
            const auto got = mesh_keys(m.extract(q));
            EXPECT_EQ(got.size(), expect.size());
            EXPECT_TRUE(got == expect);
            ++compared;
            nonempty += !expect.empty();
        }
    }
    EXPECT_EQ(models, small_cases().size());
    EXPECT_GE(compared, 8 * small_cases().size());  // at least 8 queries per model
    EXPECT_EQ(nonempty, compared);                  // every oracle mesh has tets
}

TEST(MtExtract, CoarserBoundsGiveFewerTets) {
    const Case c{{17, 17, 17}, ValueType::U8, Field::Smooth};
    const Volume* vol;
    const MtModel& m = model_of(c, &vol);
    size_t prev = std::numeric_limits<size_t>::max();
    for (double e : {0.0, 1.0, 4.0, 16.0, 64.0, 1000.0}) {
        LodQuery q;
        q.error_in = e;
        const size_t t = m.extract(q).tet_count();
        EXPECT_LE(t, prev) << "eps " << e;
        prev = t;
    }
}

TEST(MtBuild, DeterministicRebuilds) {
    for (const Case& c : {Case{{9, 9, 9}, ValueType::U8, Field::Plateau}, Case{{12, 9, 7}, ValueType::F32, Field::Noisy}}) {
        SCOPED_TRACE(case_str(c));
        const Volume v = make_volume(c.dims, c.type, c.field, 3);
        const MtModel a = MtModel::build(v), b = MtModel::build(v);
        ASSERT_EQ(a.updates().size(), b.updates().size());
        for (size_t k = 0; k < a.updates().size(); ++k) {
            const MtSplit &x = a.updates()[k], &y = b.updates()[k];
            ASSERT_TRUE(x.w == y.w && a.survivor(k) == b.survivor(k) && x.label == y.label && x.star == y.star &&
                        std::memcmp(&x.error, &y.error, 4) == 0)
                << "update " << k;
        }
        EXPECT_TRUE(a.base_tets() == b.base_tets());
        EXPECT_TRUE(a.mask_bits() == b.mask_bits());
    }
}

TEST(MtBuild, RefusesFlatVolumes) {
    EXPECT_THROW(MtModel::build(make_volume({1, 5, 5}, ValueType::U8, Field::Smooth)), Error);
    EXPECT_THROW(MtModel::build(make_volume({4, 1, 5}, ValueType::U8, Field::Smooth)), Error);
}

TEST(MtExtract, RejectsBadQueries) {
    const MtModel& m = model_of({{5, 3, 7}, ValueType::U8, Field::Noisy});
    LodQuery q;
    q.box = std::array<int64_t, 6>{3, 0, 0, 1, 2, 2};
    EXPECT_THROW(m.extract(q), Error);
    LodQuery q2;
    q2.isovalues = {std::nan("")};
    EXPECT_THROW(m.extract(q2), Error);
}

// Real data (TETLOD_DATA_DIR, optional): bucky 32^3 and head_mr at a few errors.
TEST(MtRealData, BuckyAndHeadMr) {
    struct R {
        const char* file;
        Dims dims;
    };
    int found = 0;
    for (const R& r : {R{"bucky_32x32x32_uint8.raw", {32, 32, 32}}, R{"head_mr_48x62x42_uint8.raw", {48, 62, 42}}}) {
        auto vol = read_raw(shared_data_path(r.file), r.dims, ValueType::U8);
        if (!vol) continue;
        ++found;
        SCOPED_TRACE(r.file);
        const auto t0 = std::chrono::steady_clock::now();
        const MtModel m = MtModel::build(*vol);
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("[ mt ] %s: built in %.2f s, %zu updates, base %zu tets\n", r.file, secs, m.updates().size(),
                    m.base_tets().size());
        const int64_t X = r.dims.x - 1, Y = r.dims.y - 1, Z = r.dims.z - 1;
        std::vector<LodQuery> qs;
        for (double e : {0.0, 2.0, 8.0, 32.0}) {
            LodQuery q;
            q.error_in = e;
            qs.push_back(q);
        }
        LodQuery b;
        b.error_in = 1.0, b.error_out = 40.0;
        b.box = std::array<int64_t, 6>{X / 4, Y / 4, Z / 4, X / 2, Y / 2, Z / 2};
        qs.push_back(b);
        LodQuery iso;
        iso.error_in = 2.0, iso.error_out = 64.0;
        iso.isovalues = {100.0};
        qs.push_back(iso);
        LodQuery full;
        full.full = true;
        qs.push_back(full);
        for (const LodQuery& q : qs) {
            SCOPED_TRACE(query_str(q));
            const TetMesh mesh = m.extract(q);
            if (q.full) {
                EXPECT_EQ(int64_t(mesh.tet_count()), 5 * cells(r.dims));
            }
            std::printf("[ mt ]   %-40s %9zu tets\n", query_str(q).c_str(), mesh.tet_count());
            EXPECT_TRUE(mesh_ok(*vol, mesh, mt_check_options(q, *vol)));
        }
    }
    if (found == 0) GTEST_SKIP() << "real datasets (bucky_32x32x32_uint8.raw, head_mr_48x62x42_uint8.raw) not found";
}

}  // namespace
}  // namespace tetlod::test
