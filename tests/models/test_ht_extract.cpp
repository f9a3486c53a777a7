// HT selective refinement against the independent oracle in tests/support: every
// extracted mesh must be a conforming tiling of the data box made of HT tets, honour
// the query's bound at every grid point, be the coarsest such mesh (no mergeable
// diamond; equal to the brute-force oracle for k <= 5), and the model's stored
// per-diamond errors must be the exact ones (rounded up to float).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include "region_oracles.hpp"
#include "support/ht_reference.hpp"
#include "support/mesh_checker.hpp"
#include "support/volume_generators.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/lod_query.hpp"

namespace tetlod::test {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string dims_str(const Dims& d) {
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z);
}

std::string query_str(const LodQuery& q) {
    std::ostringstream o;
    if (q.full) return "full";
    o << "eps_in=" << q.error_in;
    if (q.has_region()) o << " eps_out=" << q.error_out;
    if (q.box) {
        auto& b = *q.box;
        o << " box=[" << b[0] << "," << b[1] << "," << b[2] << ".." << b[3] << "," << b[4] << "," << b[5] << "]";
    }
    for (double v : q.isovalues) o << " iso=" << v;
    for (const auto& r : q.regions) o << " " << r->describe();
    return o.str();
}

Pt box_max_of(const Volume& v) {
    return {static_cast<int32_t>(v.dims.x - 1), static_cast<int32_t>(v.dims.y - 1),
            static_cast<int32_t>(v.dims.z - 1)};
}

/// The bound a query puts on tet T, from the definitions. Isovalue regions: the model
/// may use a conservative (wider) range, so a tet whose exact range contains an
/// isovalue must honour eps_in, any other tet the weaker of the two.
/// `exact_region` false gives the weakest bound (used for the point check of iso queries).
TetBound query_bound(const LodQuery& q, const Volume& field, bool for_minimality = false) {
    auto clamp0 = [](double e) { return e < 0 ? 0.0 : e; };
    if (q.full) return uniform_bound(0.0);
    if (!q.has_region()) return uniform_bound(for_minimality ? q.error_in : clamp0(q.error_in));
    return [q, &field, for_minimality, clamp0](const TetPts& t) {
        bool in = true;
        if (q.box) {
            auto& b = *q.box;
            in = tet_meets_box(t, {int32_t(b[0]), int32_t(b[1]), int32_t(b[2])},
                               {int32_t(b[3]), int32_t(b[4]), int32_t(b[5])});
        }
        in = in && oracle_meets_regions(q, t);
        bool iso_exact = true;
        if (in && !q.isovalues.empty()) {
            TetStats s = exact_tet_stats(field, t);
            iso_exact = false;
            for (double v : q.isovalues) iso_exact = iso_exact || (s.fmin <= v && v <= s.fmax);
        }
        double e;
        if (in && iso_exact) e = q.error_in;
        else if (in) e = std::max(q.error_in, q.error_out);  // conservative ranges may say "in"
        else e = q.error_out;
        return for_minimality ? e : clamp0(e);
    };
}

struct Checked {
    TetMesh mesh;
    double seconds = 0;
};

/// Oracle state shared by the queries of one model (k <= 5 only).
struct OracleCtx {
    std::unique_ptr<HtHierarchy> h;
    std::unique_ptr<HtOracle> oracle;
    void prepare(int k, const Volume& field) {
        h = std::make_unique<HtHierarchy>(k);
        oracle = std::make_unique<HtOracle>(*h, field);
    }
};

/// Runs one query through the model and every applicable check.
Checked run_query(const HtModel& model, const LodQuery& q, const std::string& label, OracleCtx* oracle,
                  bool minimality = true) {
    SCOPED_TRACE(label + " query{" + query_str(q) + "}");
    Checked c;
    auto t0 = std::chrono::steady_clock::now();
    c.mesh = model.extract(q);
    c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const Volume& field = model.field();
    const Pt bmax = box_max_of(field);

    CheckOptions opt;
    opt.allowed = query_bound(q, field);
    opt.tolerance = float_tolerance(field);
    EXPECT_TRUE(mesh_ok(field, c.mesh, opt));
    if (!c.mesh.level.empty()) {
        EXPECT_EQ(c.mesh.level.size(), c.mesh.tets.size());
    }

    MeshWalk w = walk_mesh(c.mesh, model.domain().k, bmax);
    EXPECT_TRUE(w.errors.empty()) << w.errors.size() << " HT-structure errors, first: " << w.errors.front();

    const bool exact_semantics = q.isovalues.empty() && !q.full;
    auto stored = [&model, &field](const Pt& p) {
        return static_cast<double>(model.diamond_errors()[field.dims.index(p[0], p[1], p[2])]);
    };
    if (minimality && exact_semantics && w.errors.empty()) {
        int64_t cand = 0;
        auto m = find_mergeable_diamonds(field, w, query_bound(q, field, true), stored, &cand);
        EXPECT_TRUE(m.empty()) << m.size() << " problems among " << cand << " merge candidates, first: " << m.front();
    }
    if (oracle && oracle->oracle && exact_semantics) {
        TetBound eps = query_bound(q, field, true);
        if (q.full) eps = uniform_bound(-1.0);
        OracleResult r = oracle->oracle->extract(eps, stored);
        std::vector<TetKey> got;
        for (std::size_t i = 0; i < c.mesh.tets.size(); ++i) got.push_back(tet_key(tet_points(c.mesh, i)));
        std::sort(got.begin(), got.end());
        if (got != r.mesh) {
            std::vector<TetKey> extra, missing;
            std::set_difference(got.begin(), got.end(), r.mesh.begin(), r.mesh.end(), std::back_inserter(extra));
            std::set_difference(r.mesh.begin(), r.mesh.end(), got.begin(), got.end(), std::back_inserter(missing));
            auto ks = [](const TetKey& k) {
                std::string s;
                for (int i = 0; i < 4; ++i)
                    s += "(" + std::to_string(k[3 * i]) + "," + std::to_string(k[3 * i + 1]) + "," +
                         std::to_string(k[3 * i + 2]) + ")";
                return s;
            };
            ADD_FAILURE() << "mesh differs from the oracle: model " << got.size() << " tets, oracle "
                          << r.mesh.size() << "; " << extra.size() << " extra, " << missing.size() << " missing"
                          << (extra.empty() ? "" : "; first extra " + ks(extra[0]))
                          << (missing.empty() ? "" : "; first missing " + ks(missing[0]));
        }
    }
    return c;
}

/// The stored per-diamond errors against the brute-force exact ones.
void check_diamond_errors(const HtModel& model, const OracleCtx& oc, const std::string& label) {
    SCOPED_TRACE(label);
    const Volume& field = model.field();
    const HtHierarchy& h = *oc.h;
    OracleResult r = oc.oracle->extract(uniform_bound(kInf));
    const int64_t N = h.L + 1;
    const auto& e = model.diamond_errors();
    ASSERT_EQ(static_cast<int64_t>(e.size()), field.count());
    // Integer data: the exact error is a dyadic rational, so the stored float must be
    // the exact value rounded up (equal when representable). Float data: the model
    // may compute in double; allow 1e-12 of the value range before rounding up.
    const auto range = field.range();
    const double slack = is_float(field.type) ? 1e-12 * std::max(1e-300, range[1] - range[0]) : 0.0;
    int unsound = 0, loose = 0, forced = 0;
    for (int64_t z = 0; z < field.dims.z; ++z)
        for (int64_t y = 0; y < field.dims.y; ++y)
            for (int64_t x = 0; x < field.dims.x; ++x) {
                const int64_t c = (z * N + y) * N + x;
                const Pt p{int32_t(x), int32_t(y), int32_t(z)};
                if (diamond_size_in_cube(p, h.k) == 0) continue;  // cube corner
                const double got = e[field.dims.index(x, y, z)];
                const double ex = r.diamond_error[c];
                std::ostringstream where;
                where << "diamond (" << x << "," << y << "," << z << "): stored " << std::setprecision(17) << got
                      << ", exact " << ex;
                if (r.diamond_forced[c]) {
                    if (!std::isinf(got) && forced++ < 3)
                        ADD_FAILURE() << where.str() << ": must be +inf (one of its tets crosses the data box)";
                } else if (r.diamond_has_inside[c]) {
                    if (!(got >= ex) && unsound++ < 3)
                        ADD_FAILURE() << where.str() << ": UNSOUND, below the exact error";
                    else if (got > round_up_to_float(ex + slack) && loose++ < 3)
                        ADD_FAILURE() << where.str() << ": LOOSE, above the exact error rounded up to float ("
                                      << std::setprecision(17) << double(round_up_to_float(ex + slack))
                                      << "); ties at eps == error then split";
                }
            }
    EXPECT_EQ(forced, 0) << "diamonds with a crossing tet not marked +inf";
    EXPECT_EQ(unsound, 0) << "diamonds whose stored error is below the exact one";
    EXPECT_EQ(loose, 0) << "diamonds whose stored error is above the exact one rounded up to float";
}

struct SynthCase {
    Dims dims;
    ValueType type;
    Field field;
};

std::string case_name(const SynthCase& c) {
    return dims_str(c.dims) + "_" + value_type_name(c.type) + "_" + field_name(c.field);
}

// ctest's list shows the case by name, not by its bytes (padding included).
void PrintTo(const SynthCase& c, std::ostream* os) { *os << case_name(c); }

class HtSynthetic : public ::testing::TestWithParam<SynthCase> {};

TEST_P(HtSynthetic, QueriesPassTheOracle) {
    const SynthCase& sc = GetParam();
    const std::string label = case_name(sc);
    Volume v = make_volume(sc.dims, sc.type, sc.field, 7);
    HtModel model = HtModel::build(v);
    const HtDomain& dom = model.domain();
    ASSERT_EQ(model.field().dims, sc.dims);
    ASSERT_EQ(model.field().data, v.data);
    ASSERT_GE(int64_t{dom.L}, std::max({sc.dims.x, sc.dims.y, sc.dims.z}) - 1);
    ASSERT_LT(int64_t{dom.L} / 2, std::max({sc.dims.x, sc.dims.y, sc.dims.z}) - 1);

    OracleCtx oracle;
    if (dom.k <= 5) {
        oracle.prepare(dom.k, model.field());
        check_diamond_errors(model, oracle, label);
    }
    const auto range = v.range();
    const double span = range[1] - range[0];
    const int64_t unit_tets = 6 * (sc.dims.x - 1) * (sc.dims.y - 1) * (sc.dims.z - 1);
    const bool cube = sc.dims.x == sc.dims.y && sc.dims.y == sc.dims.z && sc.dims.x == dom.L + 1;

    {
        LodQuery q;
        q.full = true;
        auto c = run_query(model, q, label, &oracle);
        EXPECT_EQ(static_cast<int64_t>(c.mesh.tet_count()), unit_tets) << label << " full";
        EXPECT_EQ(static_cast<int64_t>(c.mesh.vertex_count()), sc.dims.count()) << label << " full";
    }
    {
        LodQuery q;
        q.error_in = -1;
        auto c = run_query(model, q, label, &oracle);
        EXPECT_EQ(static_cast<int64_t>(c.mesh.tet_count()), unit_tets) << label << " eps<0";
    }
    {
        LodQuery q;
        q.error_in = 0;
        run_query(model, q, label, &oracle);  // bound 0 at every grid point
    }
    for (double pct : {0.5, 1.0, 5.0, 10.0, 25.0, 60.0}) {
        LodQuery q;
        q.error_in = pct * span / 100;
        run_query(model, q, label, &oracle);
    }
    {
        LodQuery q;  // unbounded
        auto c = run_query(model, q, label, &oracle);
        if (cube) {
            EXPECT_EQ(c.mesh.tet_count(), 6u) << label << " unbounded on a cube";
        }
    }
    // box queries: a middle box, a single grid point, a box covering everything, a
    // box reaching past the data
    const int32_t X = int32_t(sc.dims.x - 1), Y = int32_t(sc.dims.y - 1), Z = int32_t(sc.dims.z - 1);
    std::vector<std::array<int64_t, 6>> boxes = {
        {X / 3, Y / 3, Z / 3, (2 * X) / 3, (2 * Y) / 3, (2 * Z) / 3},
        {X / 2, Y / 2, Z / 2, X / 2, Y / 2, Z / 2},
        {0, 0, 0, X, Y, Z},
        {X / 2, 0, Z / 2, X + 5, Y / 4, Z + 3},
    };
    for (auto& b : boxes) {
        LodQuery q;
        q.box = b;
        q.error_in = 0.01 * span;
        q.error_out = 0.3 * span;
        run_query(model, q, label, &oracle);
        q.error_in = 0;
        q.error_out = kInf;
        run_query(model, q, label, &oracle);
    }
    // isovalue queries
    {
        LodQuery q;
        q.isovalues = {range[0] + 0.5 * span};
        q.error_in = 0.01 * span;
        q.error_out = kInf;
        run_query(model, q, label, &oracle);
        q.isovalues.push_back(range[0] + 0.25 * span);
        q.error_in = 0;
        q.error_out = 0.2 * span;
        run_query(model, q, label, &oracle);
        q.box = boxes[0];  // box AND iso
        run_query(model, q, label, &oracle);
    }
    // sphere queries (a registered region): centred inside, on a corner, reaching
    // in from outside, a single point, and AND-ed with a box
    const int64_t R = std::max<int64_t>(1, std::max({X, Y, Z}) / 4);
    const std::vector<std::pair<std::array<int64_t, 3>, int64_t>> spheres = {
        {{X / 2, Y / 2, Z / 2}, R}, {{0, 0, 0}, R + 1}, {{X + R / 2 + 1, Y / 2, Z / 3}, R}, {{X / 3, Y, Z / 2}, 0}};
    for (const auto& [centre, radius] : spheres) {
        LodQuery q;
        q.regions = {sphere_region(centre, radius)};
        q.error_in = 0;
        q.error_out = kInf;
        run_query(model, q, label, &oracle);
        q.error_in = 0.02 * span;
        q.error_out = 0.4 * span;
        run_query(model, q, label, &oracle);
    }
    {
        LodQuery q;
        q.regions = {sphere_region({X / 2, Y / 2, Z / 2}, R + 1)};
        q.box = std::array<int64_t, 6>{0, 0, 0, X / 2, Y, Z};
        q.error_in = 0;
        q.error_out = kInf;
        run_query(model, q, label, &oracle);
    }
}

INSTANTIATE_TEST_SUITE_P(
    Dims, HtSynthetic,
    ::testing::Values(SynthCase{{2, 2, 2}, ValueType::U8, Field::Noisy},
                      SynthCase{{3, 3, 3}, ValueType::I16, Field::Smooth},
                      SynthCase{{2, 9, 5}, ValueType::I32, Field::Noisy},
                      SynthCase{{5, 3, 17}, ValueType::U16, Field::Noisy},
                      SynthCase{{5, 3, 17}, ValueType::U8, Field::Constant},
                      SynthCase{{9, 9, 9}, ValueType::F32, Field::Smooth},
                      SynthCase{{9, 9, 9}, ValueType::F64, Field::Noisy},
                      SynthCase{{17, 17, 17}, ValueType::U8, Field::Plateau},
                      SynthCase{{17, 17, 17}, ValueType::I32, Field::Smooth},
                      SynthCase{{13, 9, 7}, ValueType::U8, Field::Plateau},
                      SynthCase{{33, 33, 33}, ValueType::I16, Field::Smooth},
                      SynthCase{{33, 33, 33}, ValueType::U8, Field::Noisy},
                      SynthCase{{40, 33, 20}, ValueType::F64, Field::Smooth},
                      SynthCase{{40, 33, 20}, ValueType::U8, Field::Plateau}),
    [](const ::testing::TestParamInfo<SynthCase>& i) { return case_name(i.param); });

// ---- non-cube domains: the coarsest meshes of docs/ht.md

TEST(HtDomainRules, CoarsestMeshCounts) {
    struct Case {
        Dims dims;
        std::size_t tets;
    };
    for (auto c : {Case{{33, 33, 33}, 6}, Case{{41, 41, 41}, 276}, Case{{32, 32, 32}, 12738},
                   Case{{64, 64, 64}, 54036}, Case{{48, 62, 42}, 37408}}) {
        const std::string label = dims_str(c.dims);
        SCOPED_TRACE(label);
        Volume v = make_volume(c.dims, ValueType::U8, Field::Noisy, 3);
        HtModel model = HtModel::build(v);
        EXPECT_FALSE(model.domain().padded);
        LodQuery q;  // unbounded
        auto r = run_query(model, q, label, nullptr);
        EXPECT_EQ(r.mesh.tet_count(), c.tets) << label;
    }
}

TEST(HtDomainRules, PaddedCube) {
    Volume v = make_volume({32, 32, 32}, ValueType::U8, Field::Smooth, 5);
    Volume padded = pad_to_cube(v);
    HtBuildOptions opt;
    opt.pad = true;
    HtModel model = HtModel::build(v, opt);
    EXPECT_TRUE(model.domain().padded);
    ASSERT_EQ(model.field().dims, padded.dims);
    EXPECT_TRUE(model.field().data == padded.data) << "padding must clamp to the nearest data value";
    OracleCtx oracle;
    oracle.prepare(model.domain().k, model.field());
    check_diamond_errors(model, oracle, "pad 32^3");
    LodQuery full;
    full.full = true;
    auto f = run_query(model, full, "pad 32^3", &oracle);
    EXPECT_EQ(f.mesh.tet_count(), 196608u);
    LodQuery unb;
    auto u = run_query(model, unb, "pad 32^3", &oracle);
    EXPECT_EQ(u.mesh.tet_count(), 6u);
    LodQuery five;
    five.error_in = 0.05 * 255;
    run_query(model, five, "pad 32^3", &oracle);
}

TEST(HtShapes, QualityOfTheThreeShapes) {
    // exact longest-edge bisection: sqrt(3)/2 for levels 0, 1 mod 3, sqrt(5)/2 for 2 mod 3
    // (the paper prints 0.75 and 1.19)
    const auto roots = ht_roots(3);
    std::vector<HtTet> t(roots.begin(), roots.end());
    for (int l = 0; l < 9; ++l) {
        const double want = l % 3 == 2 ? std::sqrt(5.0) / 2 : std::sqrt(3.0) / 2;
        for (auto& x : t) ASSERT_NEAR(shape_ratio(x.x), want, 1e-12) << "level " << l;
        std::vector<HtTet> next;
        for (auto& x : t)
            for (auto& c : ht_children(x)) next.push_back(c);
        t = std::move(next);
    }
    EXPECT_NEAR(std::sqrt(3.0) / 2, 0.8660254, 1e-7);
    EXPECT_NEAR(std::sqrt(5.0) / 2, 1.1180340, 1e-7);
}

// ---- real data (TETLOD_DATA_DIR, optional)

struct RealCase {
    const char* file;
    Dims dims;
    ValueType type;
};

void PrintTo(const RealCase& c, std::ostream* os) { *os << c.file; }

class HtRealData : public ::testing::TestWithParam<RealCase> {};

TEST_P(HtRealData, QueriesPassTheChecker) {
    const RealCase& rc = GetParam();
    auto vol = read_raw(shared_data_path(rc.file), rc.dims, rc.type);
    if (!vol) GTEST_SKIP() << "shared data file " << shared_data_path(rc.file) << " not available";
    const std::string label = rc.file;
    auto t0 = std::chrono::steady_clock::now();
    HtModel model = HtModel::build(*vol);
    const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    OracleCtx oracle;
    if (model.domain().k <= 5) {
        oracle.prepare(model.domain().k, model.field());
        check_diamond_errors(model, oracle, label);
    }
    const auto range = vol->range();
    const double span = range[1] - range[0];
    const int32_t X = int32_t(rc.dims.x - 1), Y = int32_t(rc.dims.y - 1), Z = int32_t(rc.dims.z - 1);
    std::ostringstream stats;
    stats << label << ": build " << build_s << " s";
    for (double pct : {1.0, 5.0}) {
        LodQuery q;
        q.error_in = pct * span / 100;
        auto c = run_query(model, q, label, oracle.h ? &oracle : nullptr);
        stats << "; " << pct << "%: " << c.mesh.tet_count() << " tets (" << c.seconds << " s)";
    }
    {
        LodQuery q;
        q.box = std::array<int64_t, 6>{X / 4, Y / 4, Z / 4, X / 2, Y / 2, Z / 2};
        q.error_in = 0.01 * span;
        q.error_out = 0.2 * span;
        auto c = run_query(model, q, label, oracle.h ? &oracle : nullptr);
        stats << "; box: " << c.mesh.tet_count();
    }
    {
        LodQuery q;
        q.isovalues = {range[0] + 0.3 * span};
        q.error_in = 0.01 * span;
        q.error_out = 0.25 * span;
        auto c = run_query(model, q, label, nullptr);
        stats << "; iso: " << c.mesh.tet_count();
    }
    std::printf("%s\n", stats.str().c_str());
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, HtRealData,
    ::testing::Values(RealCase{"bucky_32x32x32_uint8.raw", {32, 32, 32}, ValueType::U8},
                      RealCase{"m4_total_density_25x22x31_float32.raw", {25, 22, 31}, ValueType::F32},
                      RealCase{"head_mr_48x62x42_uint8.raw", {48, 62, 42}, ValueType::U8},
                      RealCase{"neghip_64x64x64_uint8.raw", {64, 64, 64}, ValueType::U8},
                      RealCase{"iron_protein_68x68x68_uint8.raw", {68, 68, 68}, ValueType::U8},
                      RealCase{"headsq_64x64x93_int16.raw", {64, 64, 93}, ValueType::I16}),
    [](const ::testing::TestParamInfo<RealCase>& i) {
        std::string s = i.param.file;
        s = s.substr(0, s.find('_'));
        return s;
    });

}  // namespace
}  // namespace tetlod::test
