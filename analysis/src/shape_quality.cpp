#include "tetlod/analysis/shape_quality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tetlod {

double circumradius_to_shortest_edge(const WorldTet& t) {
    // Circumcentre relative to t[0]: solve 2 [a;b;c] x = [|a|^2;|b|^2;|c|^2]
    // with a, b, c the edge vectors from t[0] (Cramer's rule).
    double e[3][3];
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a) e[i][a] = t[i + 1][a] - t[0][a];
    auto dot = [](const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
    auto cross = [](const double* u, const double* v, double* o) {
        o[0] = u[1] * v[2] - u[2] * v[1];
        o[1] = u[2] * v[0] - u[0] * v[2];
        o[2] = u[0] * v[1] - u[1] * v[0];
    };
    double bc[3], ca[3], ab[3];
    cross(e[1], e[2], bc);
    cross(e[2], e[0], ca);
    cross(e[0], e[1], ab);
    const double det = dot(e[0], bc);
    if (det == 0) return std::numeric_limits<double>::infinity();
    const double la = dot(e[0], e[0]), lb = dot(e[1], e[1]), lc = dot(e[2], e[2]);
    double x[3];
    for (int a = 0; a < 3; ++a) x[a] = (la * bc[a] + lb * ca[a] + lc * ab[a]) / (2 * det);
    const double R = std::sqrt(dot(x, x));
    double shortest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
            double d2 = 0;
            for (int a = 0; a < 3; ++a) d2 += (t[i][a] - t[j][a]) * (t[i][a] - t[j][a]);
            shortest = std::min(shortest, std::sqrt(d2));
        }
    return R / shortest;
}

ShapeQualityStats shape_quality(const TetMesh& mesh, int bins) {
    ShapeQualityStats s;
    s.histogram.assign(std::max(bins, 1), 0);
    s.min = std::numeric_limits<double>::infinity();
    double sum = 0;
    for (const auto& tet : mesh.tets) {
        WorldTet w;
        for (int i = 0; i < 4; ++i) w[i] = mesh.geometry.world(mesh.points[tet[i]]);
        const double q = circumradius_to_shortest_edge(w);
        s.min = std::min(s.min, q);
        s.max = std::max(s.max, q);
        sum += q;
        int b = int((q - s.hist_lo) / (s.hist_hi - s.hist_lo) * double(s.histogram.size()));
        b = std::clamp(b, 0, int(s.histogram.size()) - 1);
        ++s.histogram[b];
        ++s.count;
    }
    if (s.count == 0) s.min = 0;
    s.mean = s.count ? sum / double(s.count) : 0.0;
    return s;
}

}  // namespace tetlod
