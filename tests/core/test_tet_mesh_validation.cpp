// The one TetMesh consistency check: every kind of inconsistency is found and
// named (array, index, counts), and the consumers refuse such meshes with it.
#include <gtest/gtest.h>

#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"

using namespace tetlod;

namespace {

TetMesh unit_tet() {
    TetMesh m;
    m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    m.values = {0, 1, 2, 3};
    m.tets = {{0, 1, 2, 3}};
    m.level = {0};
    m.error = {0.5f};
    return m;
}

}  // namespace

TEST(TetMeshValidation, AConsistentMeshPasses) {
    EXPECT_EQ(tet_mesh_problem(unit_tet()), "");
    EXPECT_EQ(tet_mesh_problem(unit_tet(), {.orientation = true}), "");
    TetMesh no_extras = unit_tet();
    no_extras.level.clear();
    no_extras.error.clear();
    EXPECT_EQ(tet_mesh_problem(no_extras), "");
    EXPECT_NO_THROW(validate(no_extras, "test"));
}

TEST(TetMeshValidation, EachInconsistencyIsNamed) {
    TetMesh m = unit_tet();
    m.values.pop_back();
    EXPECT_EQ(tet_mesh_problem(m), "3 values for 4 points");
    m = unit_tet();
    m.level = {0, 1};
    EXPECT_EQ(tet_mesh_problem(m), "2 levels for 1 tets");
    m = unit_tet();
    m.error = {1, 2, 3};
    EXPECT_EQ(tet_mesh_problem(m), "3 errors for 1 tets");
    m = unit_tet();
    m.tets.push_back({0, 1, 2, 4});
    m.level.push_back(0);
    m.error.push_back(0);
    EXPECT_EQ(tet_mesh_problem(m), "tet 1 uses vertex 4 of 4 points");
}

TEST(TetMeshValidation, OrientationOnlyWhenAsked) {
    TetMesh m = unit_tet();
    m.tets = {{0, 2, 1, 3}};  // inverted
    EXPECT_EQ(tet_mesh_problem(m), "");
    EXPECT_EQ(tet_mesh_problem(m, {.orientation = true}), "tet 0 is degenerate or inverted (6 x volume = -1 in grid units)");
    m.points[3] = {1, 1, 0};  // flat
    m.tets = {{0, 1, 2, 3}};
    EXPECT_EQ(tet_mesh_problem(m, {.orientation = true}), "tet 0 is degenerate or inverted (6 x volume = 0 in grid units)");
    // Far-apart points: the triple product needs more than 64 bits.
    m.points = {{-2000000000, -2000000000, -2000000000}, {2000000000, -2000000000, -2000000000},
                {-2000000000, 2000000000, -2000000000}, {-2000000000, -2000000000, 2000000000}};
    EXPECT_EQ(tet_mesh_problem(m, {.orientation = true}), "");
}

TEST(TetMeshValidation, ValidateThrowsWithTheContext) {
    TetMesh m = unit_tet();
    m.tets[0][2] = 9;
    try {
        validate(m, "cannot write 'x.vtu'");
        FAIL() << "no throw";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
        EXPECT_NE(std::string(e.what()).find("cannot write 'x.vtu': tet 0 uses vertex 9 of 4 points"), std::string::npos)
            << e.what();
    }
}
