// The sphere region: tets that meet a closed ball given in grid index
// coordinates ("a finer LOD around a point", as view-dependent and focus+context
// renderers ask). `--sphere cx,cy,cz,r` on the command line.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "tetlod/core/error.hpp"
#include "tetlod/models/query_region.hpp"

namespace tetlod {

namespace {

using Vec = std::array<double, 3>;

Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(const Vec& a, const Vec& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec at(const Vec& a, const Vec& d, double t) { return {a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]}; }

// Closest point of triangle abc to p, by the Voronoi region of p (vertex, edge
// or face region of the triangle).
Vec closest_on_triangle(const Vec& p, const Vec& a, const Vec& b, const Vec& c) {
    const Vec ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const Vec bp = sub(p, b);
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return at(a, ab, d1 / (d1 - d3));
    const Vec cp = sub(p, c);
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return at(a, ac, d2 / (d2 - d6));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return at(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    const double denom = 1.0 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    return {a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w};
}

class SphereRegion final : public QueryRegion {
public:
    SphereRegion(const Vec& centre, double radius) : c_(centre), r_(radius) {
        // Tangency computed in floating point may land a hair outside: widen the
        // ball by a few ulps of the coordinates so such tets count as meeting it
        // (a finer mesh, never a broken promise).
        const double scale = std::max({std::abs(c_[0]), std::abs(c_[1]), std::abs(c_[2]), r_, 1.0});
        const double r = r_ + 1e-9 * scale;
        r2_ = r * r;
    }

    bool meets(const TetCorners& t, const std::array<double, 4>&, double) const override {
        Vec v[4];
        for (int i = 0; i < 4; ++i) v[i] = {double(t[i][0]), double(t[i][1]), double(t[i][2])};
        // Quick accept: a corner in the ball; quick reject: the bounding box misses it.
        double box_d2 = 0;
        for (int a = 0; a < 3; ++a) {
            const double lo = std::min({v[0][a], v[1][a], v[2][a], v[3][a]});
            const double hi = std::max({v[0][a], v[1][a], v[2][a], v[3][a]});
            const double d = c_[a] < lo ? lo - c_[a] : (c_[a] > hi ? c_[a] - hi : 0.0);
            box_d2 += d * d;
        }
        if (box_d2 > r2_) return false;
        for (const Vec& p : v)
            if (dot(sub(p, c_), sub(p, c_)) <= r2_) return true;
        if (inside(v)) return true;
        static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
        for (const auto& f : kFaces) {
            const Vec q = closest_on_triangle(c_, v[f[0]], v[f[1]], v[f[2]]);
            if (dot(sub(q, c_), sub(q, c_)) <= r2_) return true;
        }
        return false;
    }

    std::string describe() const override {
        auto n = [](double x) {
            std::string s = std::to_string(x);
            s.erase(s.find_last_not_of('0') + 1);
            if (!s.empty() && s.back() == '.') s.pop_back();
            return s;
        };
        return "sphere " + n(c_[0]) + "," + n(c_[1]) + "," + n(c_[2]) + " r " + n(r_);
    }

private:
    // The centre on the inner side of (or on) every face plane.
    bool inside(const Vec v[4]) const {
        static constexpr int kOpposite[4][4] = {{1, 2, 3, 0}, {0, 2, 3, 1}, {0, 1, 3, 2}, {0, 1, 2, 3}};
        for (const auto& f : kOpposite) {
            const Vec n = cross(sub(v[f[1]], v[f[0]]), sub(v[f[2]], v[f[0]]));
            const double side_of_vertex = dot(n, sub(v[f[3]], v[f[0]]));
            const double side_of_centre = dot(n, sub(c_, v[f[0]]));
            if (side_of_vertex * side_of_centre < 0) return false;
        }
        return true;
    }

    Vec c_;
    double r_, r2_;
};

std::shared_ptr<const QueryRegion> parse_sphere(const std::string& text) {
    double x[4];
    std::size_t pos = 0;
    for (int i = 0; i < 4; ++i) {
        const std::size_t end = text.find(',', pos);
        if ((i < 3) != (end != std::string::npos))
            throw Error(ErrorCode::InvalidArgument, "sphere '" + text + "': expected cx,cy,cz,r");
        const std::string item = text.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
        std::size_t used = 0;
        try {
            x[i] = std::stod(item, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || used != item.size() || !std::isfinite(x[i]))
            throw Error(ErrorCode::InvalidArgument, "sphere '" + text + "': '" + item + "' is not a finite number");
        pos = end + 1;
    }
    if (x[3] < 0) throw Error(ErrorCode::InvalidArgument, "sphere '" + text + "': the radius is negative");
    return std::make_shared<SphereRegion>(Vec{x[0], x[1], x[2]}, x[3]);
}

}  // namespace

QueryRegionKind sphere_region_kind() {
    return {"sphere", "cx,cy,cz,r", "Region: tets meeting the ball of centre (cx,cy,cz) and radius r (index space)",
            parse_sphere};
}

}  // namespace tetlod
