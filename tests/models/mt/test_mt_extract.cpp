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
};

std::string case_str(const Case& c) {
    return dims_str(c.dims) + " " + value_type_name(c.type) + " " + field_name(c.field);
}

const std::vector<Case>& small_cases() {
    static const std::vector<Case> cases = {
        {{2, 2, 2}, ValueType::U8, Field::Smooth},    {{2, 3, 2}, ValueType::F32, Field::Noisy},
        {{5, 3, 7}, ValueType::U8, Field::Noisy},     {{5, 3, 7}, ValueType::I16, Field::Smooth},
        {{9, 9, 9}, ValueType::U8, Field::Plateau},   {{9, 9, 9}, ValueType::F32, Field::Smooth},
        {{12, 9, 7}, ValueType::I16, Field::Noisy},   {{12, 9, 7}, ValueType::U8, Field::Smooth},
        {{3, 11, 4}, ValueType::U8, Field::Constant}, {{17, 17, 17}, ValueType::U8, Field::Smooth},
        {{17, 17, 17}, ValueType::I16, Field::Plateau},
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
    auto grid_of = [&](uint32_t node) { return node < n ? node : ups[node - n].s; };
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
        const double err = ups[k].error;
        bool in = true;
        if (!q.full && q.has_region()) {
            const TetPts p = pts(t);
            if (q.box) {
                auto& b = *q.box;
                in = tet_meets_box(p, {int32_t(b[0]), int32_t(b[1]), int32_t(b[2])},
                                   {int32_t(b[3]), int32_t(b[4]), int32_t(b[5])});
            }
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
            const MtUpdate &x = a.updates()[k], &y = b.updates()[k];
            ASSERT_TRUE(x.w == y.w && x.s == y.s && x.label == y.label && x.star == y.star &&
                        x.mask_offset == y.mask_offset && std::memcmp(&x.error, &y.error, 4) == 0)
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
