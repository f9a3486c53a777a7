#pragma once
// Independent brute-force checker for extracted tetrahedral meshes. Written from
// the definitions in docs/ht.md; shares no code with models/ or codecs/. Everything
// geometric is exact integer arithmetic on grid coordinates (int64 / __int128):
// no tolerance anywhere except for float-valued data in the bound check.
//
// What is checked (each can be switched off in CheckOptions):
//  * validity: 4 distinct in-range vertex ids, positive orientation, vertices are
//    grid points of the data box, vertex values equal the volume exactly, no
//    duplicate vertex coordinates;
//  * conformity: every face is used by 1 tet (then it lies in a boundary plane of
//    the box) or by 2 tets on opposite sides; no mesh vertex lies in a closed tet
//    other than at its own 4 corners (hanging vertices on edges/faces, overlaps);
//    no grid point strictly inside one tet is touched by another (overlap);
//  * volume: sum of |det| equals 6 * box volume exactly;
//  * bound: every grid point of the box is covered by at least one closed tet, and
//    for every tet T and every grid point p of closed T, |f(p) - L_T(p)| <= allowed(T).
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::test {

using Pt = std::array<int32_t, 3>;
using TetPts = std::array<Pt, 4>;

/// det[(p1-p0), (p2-p0), (p3-p0)] = 6 x signed volume, exact.
int64_t tet_det(const TetPts& t);

/// Corner coordinates of tet i of a mesh.
TetPts tet_points(const TetMesh& mesh, std::size_t i);

struct TetStats {
    double error = 0.0;  // max |f - L_T| over the grid points of the closed tet
    double fmin = 0.0;   // value range over the same points
    double fmax = 0.0;
    int64_t points = 0;  // grid points in the closed tet
};

/// Exact error and value range of one tet (any orientation, nondegenerate), whose
/// grid points must all lie inside the volume. Integer data: exact (the error is
/// |f D - sum Di fi| / |D| with the numerator in __int128). Float data: long double.
TetStats exact_tet_stats(const Volume& volume, const TetPts& tet);
inline double exact_tet_error(const Volume& volume, const TetPts& tet) {
    return exact_tet_stats(volume, tet).error;
}

/// Calls f(p, inside) for every grid point p of the closed tet; inside is true when
/// p is strictly inside (all barycentric numerators nonzero).
void for_each_tet_point(const TetPts& tet, const std::function<void(const Pt&, bool)>& f);

/// Closed tet meets closed axis-aligned box [lo, hi] (separating axis test, exact).
bool tet_meets_box(const TetPts& tet, const Pt& lo, const Pt& hi);

/// Closed tet meets closed ball (integer centre and radius): exact, in integers,
/// by the feature the ball's centre is nearest to: a vertex, the inside of an
/// edge, the inside of a face, or the tet's interior.
bool tet_meets_ball(const TetPts& tet, const std::array<int64_t, 3>& centre, int64_t radius);

struct CheckOptions {
    bool validity = true;
    bool conformity = true;
    bool volume_sum = true;
    /// Per-point bound: allowed error for the grid points of a tet. Empty: not checked
    /// (coverage is still checked when `coverage` is set).
    std::function<double(const TetPts&)> allowed;
    bool coverage = true;
    /// Slack added to allowed(); 0 for integer data. Float data: a few ulps of the range.
    double tolerance = 0.0;
    int max_messages = 8;
};

/// Uniform bound helper.
inline std::function<double(const TetPts&)> uniform_bound(double eps) {
    return [eps](const TetPts&) { return eps; };
}

struct CheckReport {
    int64_t failures = 0;
    std::vector<std::string> messages;  // the first few failures, readable
    int64_t tets = 0, vertices = 0;
    int64_t boundary_faces = 0, interior_faces = 0;
    int64_t points_checked = 0;  // (tet, point) pairs evaluated
    double max_error = 0.0;      // largest |f - L_T| seen
    bool ok() const { return failures == 0; }
    std::string summary() const;
    void fail(const std::string& msg, int max_messages);
};

/// Checks `mesh` against `volume` (the field the mesh samples; the data box is
/// [0, dims-1]). Never throws on bad meshes: problems go into the report.
CheckReport check_mesh(const Volume& volume, const TetMesh& mesh, const CheckOptions& options = {});

/// gtest wrapper: EXPECT_TRUE(mesh_ok(v, m, opt)) prints the report on failure.
::testing::AssertionResult mesh_ok(const Volume& volume, const TetMesh& mesh,
                                   const CheckOptions& options = {});

/// Tolerance for float data: 1e-9 of the value range (0 for integer types).
double float_tolerance(const Volume& volume);

}  // namespace tetlod::test
