// Query regions beyond box and isovalues (tetlod/models/query_region.hpp): the
// sphere's tet test against an exact integer oracle on both sides of every
// threshold radius, its text form, the registry's rules, a region a third party
// registers used by both models from memory and from a container, and the CLI
// flag the registry generates.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <sys/wait.h>
#include <cstdio>
#include <filesystem>
#include <random>

#include "region_oracles.hpp"
#include "support/mesh_checker.hpp"
#include "support/volume_generators.hpp"
#include "tetlod/tetlod.hpp"

namespace tetlod::test {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool library_meets(const QueryRegion& r, const TetPts& t) {
    TetCorners c;
    for (int i = 0; i < 4; ++i) c[i] = t[i];
    return r.meets(c, {0, 0, 0, 0}, 0);
}

TetPts random_tet(std::mt19937& rng, int lo, int hi) {
    std::uniform_int_distribution<int> d(lo, hi);
    for (;;) {
        TetPts t;
        for (auto& p : t) p = {d(rng), d(rng), d(rng)};
        if (tet_det(t) != 0) return t;
    }
}

TEST(SphereRegion, AgreesWithTheExactOracleOnBothSidesOfEveryThreshold) {
    // Small coordinates: the smallest integer radius that meets the tet is found
    // by the oracle; the library must say no at r-1 and yes at r (exactly: its
    // floating-point slack is far below the gap between such distances here).
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> centre(-1, 9);
    int checked = 0, inside = 0, edge_or_face = 0;
    for (int n = 0; n < 20000; ++n) {
        const TetPts t = random_tet(rng, 0, 8);
        const std::array<int64_t, 3> c{centre(rng), centre(rng), centre(rng)};
        int64_t r = 0;
        while (!tet_meets_ball(t, c, r)) ++r;
        if (r == 0) ++inside;
        bool vertex_at_r = false;
        for (const auto& p : t) {
            int64_t d2 = 0;
            for (int a = 0; a < 3; ++a) d2 += (p[a] - c[a]) * (p[a] - c[a]);
            vertex_at_r = vertex_at_r || d2 <= r * r;
        }
        if (!vertex_at_r) ++edge_or_face;
        SCOPED_TRACE("tet " + std::to_string(n) + " r " + std::to_string(r));
        EXPECT_TRUE(library_meets(*sphere_region(c, r), t));
        if (r > 0) {
            EXPECT_FALSE(library_meets(*sphere_region(c, r - 1), t));
        }
        ++checked;
    }
    EXPECT_EQ(checked, 20000);
    EXPECT_GT(inside, 150);
    std::printf("sphere oracle: %d tets, %d with the centre inside, %d nearest inside an edge or face\n", checked,
                inside, edge_or_face);        // centres inside the tet were tried
    EXPECT_GT(edge_or_face, 2000);  // and nearest points inside edges and faces
}

TEST(SphereRegion, NeverMissesATetOnLargeGrids) {
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> centre(1000, 3000);
    std::uniform_int_distribution<int> radius(0, 300);
    int meets = 0;
    for (int n = 0; n < 5000; ++n) {
        const TetPts t = random_tet(rng, 1500, 2500);
        const std::array<int64_t, 3> c{centre(rng), centre(rng), centre(rng)};
        const int64_t r = radius(rng) * 3;
        const bool exact = tet_meets_ball(t, c, r);
        meets += exact;
        if (exact) {
            EXPECT_TRUE(library_meets(*sphere_region(c, r), t)) << "tet " << n;
        }
    }
    EXPECT_GT(meets, 1000);
}

TEST(SphereRegion, TextIsCheckedAndDescribed) {
    const QueryRegionKind* kind = find_query_region_kind("sphere");
    ASSERT_NE(kind, nullptr);
    EXPECT_EQ(kind->syntax, "cx,cy,cz,r");
    EXPECT_EQ(kind->parse("10,20.5,-3,4")->describe(), "sphere 10,20.5,-3 r 4");
    for (const char* bad : {"", "1,2,3", "1,2,3,4,5", "a,2,3,4", "1,2,3,-1", "1,2,3,nan", "1,inf,3,4", "1,2,,4",
                            "1,2,3,4x", " ,2,3,4"}) {
        SCOPED_TRACE(bad);
        try {
            kind->parse(bad);
            ADD_FAILURE() << "accepted";
        } catch (const Error& e) {
            EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
            EXPECT_NE(std::string(e.what()).find("sphere"), std::string::npos) << e.what();
        }
    }
}

// A region as a third party would write one: tets reaching the half-space x >= c.
class SlabRegion final : public QueryRegion {
public:
    explicit SlabRegion(int32_t x) : x_(x) {}
    bool meets(const TetCorners& t, const std::array<double, 4>&, double) const override {
        return std::max({t[0][0], t[1][0], t[2][0], t[3][0]}) >= x_;
    }
    std::string describe() const override { return "x >= " + std::to_string(x_); }

private:
    int32_t x_;
};

QueryRegionKind slab_kind() {
    return {"test-slab", "X", "Region: x >= X (test only)",
            [](const std::string& text) -> std::shared_ptr<const QueryRegion> {
                return std::make_shared<SlabRegion>(std::stoi(text));
            }};
}

TEST(QueryRegionRegistry, RefusesTakenAndMalformedNames) {
    if (!find_query_region_kind("test-slab")) register_query_region_kind(slab_kind());
    ASSERT_NE(find_query_region_kind("test-slab"), nullptr);
    auto refused = [](QueryRegionKind k, const std::string& why) {
        try {
            register_query_region_kind(std::move(k));
            ADD_FAILURE() << "registered " << why;
        } catch (const Error& e) {
            EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
        }
    };
    refused(slab_kind(), "twice");
    for (const char* name : {"box", "isovalue", "error-out", "full", "sphere", "", "Slab", "a b", "x/y"}) {
        QueryRegionKind k = slab_kind();
        k.name = name;
        refused(k, name);
    }
    QueryRegionKind no_parser = slab_kind();
    no_parser.name = "no-parser";
    no_parser.parse = nullptr;
    refused(no_parser, "without a parser");
    EXPECT_EQ(query_region_kinds().front().name, "sphere");  // built-ins first
}

TEST(QueryRegionRegistry, AThirdPartyRegionWorksOnBothModelsFromMemoryAndContainer) {
    const Volume v = make_volume({17, 13, 11}, ValueType::U8, Field::Smooth, 3);
    LodQuery q;
    q.regions = {std::make_shared<SlabRegion>(12)};
    q.error_in = 0;
    q.error_out = kInf;
    CheckOptions opt;
    opt.allowed = [](const TetPts& t) {
        return std::max({t[0][0], t[1][0], t[2][0], t[3][0]}) >= 12 ? 0.0 : kInf;
    };
    const std::string dir = TETLOD_TEST_TMP;
    const std::string path = dir + "/slab.tlod";
    std::filesystem::remove(path);
    ContainerWriteOptions wo;
    wo.ht = wo.mt = true;
    write_container(v, path, wo);
    LodQuery uniform;  // the coarsest mesh, for comparison
    for (ModelKind kind : {ModelKind::Ht, ModelKind::Mt}) {
        SCOPED_TRACE(model_kind_name(kind));
        const LodModel model = build_model(kind, v);
        const TetMesh mesh = model.extract(q);
        EXPECT_TRUE(mesh_ok(v, mesh, opt));
        EXPECT_GT(mesh.tet_count(), model.extract(uniform).tet_count());
        auto stored = extract_from_container(path, kind, q);
        ASSERT_TRUE(stored.ok()) << stored.failure().message;
        EXPECT_EQ(stored->mesh.tets, mesh.tets);
        EXPECT_EQ(stored->mesh.points, mesh.points);
    }
}

TEST(QueryRegionRegistry, ANullRegionIsRefused) {
    const LodModel model = build_model(ModelKind::Ht, make_volume({9, 9, 9}, ValueType::U8, Field::Smooth));
    LodQuery q;
    q.error_in = 0;
    q.regions = {nullptr};
    try {
        model.extract(q);
        ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
    }
}

int run_cli(const std::string& args, std::string* out = nullptr) {
    const std::string log = std::string(TETLOD_TEST_TMP) + "/cli.log";
    const int rc = std::system((std::string(TETLOD_CLI_PATH) + " " + args + " >" + log + " 2>&1").c_str());
    if (out) {
        std::ifstream f(log);
        out->assign(std::istreambuf_iterator<char>(f), {});
    }
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

TEST(QueryRegionCli, SphereFlagOnExtractDecodeAndIsosurface) {
    const std::string dir = TETLOD_TEST_TMP;
    const std::string raw = dir + "/ml_33x33x33_uint8.raw";
    ASSERT_EQ(run_cli("sample marschner-lobb " + raw + " --size 33 -f"), 0);
    std::string text;
    ASSERT_EQ(run_cli("extract " + raw + " " + dir + "/s.vtu -f --error 0 --sphere 16,16,16,5", &text), 0) << text;
    EXPECT_NE(text.find("sphere 16,16,16 r 5"), std::string::npos) << text;
    ASSERT_EQ(run_cli("extract " + raw + " " + dir + "/s.vtu -f --error 0 --sphere 16,16,16,5 --error-out 10%",
                      &text),
              0)
        << text;
    ASSERT_EQ(run_cli("extract " + raw + " " + dir + "/s.vtu -f --model mt --error 0 --sphere 0,0,0,8", &text), 0)
        << text;
    EXPECT_EQ(run_cli("extract " + raw + " " + dir + "/s.vtu -f --error 0 --sphere 1,2,3", &text), 2);
    EXPECT_NE(text.find("--sphere"), std::string::npos) << text;
    EXPECT_EQ(run_cli("extract " + raw + " " + dir + "/s.vtu -f --error 0 --sphere 1,2,3,-4", &text), 2);
    // --error-out needs a region; a sphere is one
    EXPECT_EQ(run_cli("extract " + raw + " " + dir + "/s.vtu -f --error 0 --error-out 1", &text), 2);
    ASSERT_EQ(run_cli("convert " + raw + " " + dir + "/ml.tlod -f", &text), 0) << text;
    ASSERT_EQ(run_cli("decode " + dir + "/ml.tlod " + dir + "/d.raw -f --error 0 --sphere 16,16,16,5", &text), 0)
        << text;
    ASSERT_EQ(run_cli("isosurface " + raw + " " + dir + "/s.ply -f --isovalue 128 --error 0 --sphere 16,16,16,8",
                      &text),
              0)
        << text;
    EXPECT_NE(text.find("sphere 16,16,16 r 8"), std::string::npos) << text;
}

}  // namespace
}  // namespace tetlod::test
