#include "support/ht_reference.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace tetlod::test {
namespace {

bool corners_in(const TetPts& t, const Pt& b) {
    for (auto& p : t)
        for (int a = 0; a < 3; ++a)
            if (p[a] < 0 || p[a] > b[a]) return false;
    return true;
}
// The tet's bounding box meets the open box (0,b): otherwise its interior misses B.
bool bbox_meets_interior(const TetPts& t, const Pt& b) {
    for (int a = 0; a < 3; ++a) {
        int32_t lo = std::min({t[0][a], t[1][a], t[2][a], t[3][a]});
        if (lo >= b[a]) return false;
    }
    return true;
}
bool interior_meets(const HtTet& t, const Pt& b, int k) {
    if (corners_in(t.x, b)) return true;
    if (!bbox_meets_interior(t.x, b) || t.level >= 3 * k) return false;
    auto ch = ht_children(t);
    return interior_meets(ch[0], b, k) || interior_meets(ch[1], b, k);
}
int tz(int32_t v, int k) {
    if (v == 0) return k;
    int t = 0;
    while (!(v & 1)) v >>= 1, ++t;
    return t;
}
std::string str(const Pt& p) {
    return "(" + std::to_string(p[0]) + "," + std::to_string(p[1]) + "," + std::to_string(p[2]) + ")";
}
std::string str(const TetPts& t) { return "[" + str(t[0]) + " " + str(t[1]) + " " + str(t[2]) + " " + str(t[3]) + "]"; }

}  // namespace

std::array<HtTet, 6> ht_roots(int k) {
    const int32_t L = int32_t{1} << k;
    std::array<HtTet, 6> r;
    const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int i = 0; i < 6; ++i) {
        Pt p{0, 0, 0};
        r[i].x[0] = p;
        for (int s = 0; s < 3; ++s) {
            p[perms[i][s]] = L;
            r[i].x[s + 1] = p;
        }
        r[i].tag = 3;
        r[i].level = 0;
    }
    return r;
}

Pt ht_spine_mid(const HtTet& t) {
    const Pt& a = t.x[0];
    const Pt& b = t.x[t.tag];
    return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
}

std::array<HtTet, 2> ht_children(const HtTet& t) {
    const int j = t.tag;
    const Pt z = ht_spine_mid(t);
    std::array<HtTet, 2> c;
    // first child: (x0..x_{j-1}, z, x_{j+1}..x3)
    for (int i = 0; i < 4; ++i) c[0].x[i] = t.x[i];
    c[0].x[j] = z;
    // second child: (x1..x_j, z, x_{j+1}..x3)
    for (int i = 0; i < j; ++i) c[1].x[i] = t.x[i + 1];
    c[1].x[j] = z;
    for (int i = j + 1; i < 4; ++i) c[1].x[i] = t.x[i];
    const int tag = j == 1 ? 3 : j - 1;
    for (auto& ch : c) {
        ch.tag = tag;
        ch.level = t.level + 1;
    }
    return c;
}

TetKey tet_key(const TetPts& t) {
    TetPts s = t;
    std::sort(s.begin(), s.end());
    TetKey k;
    for (int i = 0; i < 4; ++i)
        for (int a = 0; a < 3; ++a) k[3 * i + a] = s[i][a];
    return k;
}

std::size_t TetKeyHash::operator()(const TetKey& k) const {
    uint64_t h = 1469598103934665603ull;
    for (int32_t v : k) {
        h ^= static_cast<uint32_t>(v);
        h *= 1099511628211ull;
        h ^= h >> 29;
    }
    return static_cast<std::size_t>(h);
}

BoxStatus classify(const HtTet& t, const Pt& bmax, int k) {
    if (corners_in(t.x, bmax)) return BoxStatus::Inside;
    return interior_meets(t, bmax, k) ? BoxStatus::Crossing : BoxStatus::Outside;
}

int diamond_size_in_cube(const Pt& c, int k) {
    const int32_t L = int32_t{1} << k;
    int t = std::min({tz(c[0], k), tz(c[1], k), tz(c[2], k)});
    int odd[3], nodd = 0;
    for (int a = 0; a < 3; ++a) {
        odd[a] = tz(c[a], k) == t;
        nodd += odd[a];
    }
    auto n = [&](int a) { return (c[a] > 0 && c[a] < L) ? 2 : 1; };
    switch (3 - nodd) {
        case 0: return 6;
        case 1:
            for (int a = 0; a < 3; ++a)
                if (!odd[a]) return 2 * n(a);
            break;
        case 2: {
            int r = 2;
            for (int a = 0; a < 3; ++a)
                if (!odd[a]) r *= n(a);
            return r;
        }
    }
    return 0;  // a cube corner: not a diamond
}

double shape_ratio(const TetPts& t) {
    auto d = [&](int i, int a) { return double(t[i][a]) - double(t[0][a]); };
    double a[3] = {d(1, 0), d(1, 1), d(1, 2)}, b[3] = {d(2, 0), d(2, 1), d(2, 2)}, c[3] = {d(3, 0), d(3, 1), d(3, 2)};
    auto cr = [](const double* u, const double* v, double* o) {
        o[0] = u[1] * v[2] - u[2] * v[1];
        o[1] = u[2] * v[0] - u[0] * v[2];
        o[2] = u[0] * v[1] - u[1] * v[0];
    };
    auto dt = [](const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
    double bc[3], ca[3], ab[3];
    cr(b, c, bc);
    cr(c, a, ca);
    cr(a, b, ab);
    double den = 2 * dt(a, bc);
    double o[3];
    for (int i = 0; i < 3; ++i) o[i] = (dt(a, a) * bc[i] + dt(b, b) * ca[i] + dt(c, c) * ab[i]) / den;
    double R = std::sqrt(dt(o, o));
    double shortest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) {
            double s = 0;
            for (int k = 0; k < 3; ++k) s += (double(t[i][k]) - t[j][k]) * (double(t[i][k]) - t[j][k]);
            shortest = std::min(shortest, std::sqrt(s));
        }
    return R / shortest;
}

MeshWalk walk_mesh(const TetMesh& mesh, int k, const Pt& bmax) {
    MeshWalk w;
    w.k = k;
    w.bmax = bmax;
    auto err = [&](std::string s) {
        if (w.errors.size() < 20) w.errors.push_back(std::move(s));
    };
    w.node_of_tet.assign(mesh.tets.size(), HtTet{{}, 0, -1});
    w.leaf.reserve(mesh.tets.size() * 2);
    for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
        TetPts tp;
        bool ok = true;
        for (int v = 0; v < 4; ++v) {
            if (mesh.tets[i][v] >= mesh.points.size()) ok = false;
            else tp[v] = mesh.points[mesh.tets[i][v]];
        }
        if (!ok) continue;
        if (!w.leaf.emplace(tet_key(tp), static_cast<uint32_t>(i)).second)
            err("mesh tet " + std::to_string(i) + " " + str(tp) + " appears twice");
    }
    std::vector<char> found(mesh.tets.size(), 0);
    std::vector<HtTet> stack;
    for (auto& r : ht_roots(k)) stack.push_back(r);
    while (!stack.empty()) {
        HtTet t = stack.back();
        stack.pop_back();
        auto it = w.leaf.find(tet_key(t.x));
        if (it != w.leaf.end()) {
            found[it->second] = 1;
            w.node_of_tet[it->second] = t;
            if (!mesh.level.empty() && it->second < mesh.level.size() && mesh.level[it->second] != t.level)
                err("mesh tet " + std::to_string(it->second) + " " + str(t.x) + " has level " +
                    std::to_string(mesh.level[it->second]) + ", HT level is " + std::to_string(t.level));
            continue;
        }
        if (!bbox_meets_interior(t.x, bmax)) continue;  // outside B
        if (t.level >= 3 * k) {
            err("unit tet " + str(t.x) + " of B is not covered by an output tet");
            continue;
        }
        w.split.push_back(t);
        for (auto& c : ht_children(t)) stack.push_back(c);
    }
    for (std::size_t i = 0; i < mesh.tets.size(); ++i)
        if (!found[i] && mesh.tets[i][0] < mesh.points.size())
            err("mesh tet " + std::to_string(i) + " " + str(tet_points(mesh, i)) +
                " is not a node of the HT (or lies below another output tet)");
    return w;
}

std::vector<std::string> find_mergeable_diamonds(const Volume& field, const MeshWalk& w, const TetBound& eps,
                                                 const DiamondErrorFn& model_error, int64_t* checked) {
    std::vector<std::string> out;
    const int64_t N = (int64_t{1} << w.k) + 1;
    std::unordered_map<int64_t, std::vector<std::size_t>> groups;
    for (std::size_t i = 0; i < w.split.size(); ++i) {
        Pt c = ht_spine_mid(w.split[i]);
        groups[(int64_t{c[2]} * N + c[1]) * N + c[0]].push_back(i);
    }
    int64_t cand = 0;
    for (auto& [key, g] : groups) {
        const Pt c = ht_spine_mid(w.split[g[0]]);
        if (static_cast<int>(g.size()) != diamond_size_in_cube(c, w.k)) continue;  // part of it is outside B
        bool all_in = true, leaves = true;
        for (std::size_t i : g) {
            if (!corners_in(w.split[i].x, w.bmax)) all_in = false;
            for (auto& ch : ht_children(w.split[i]))
                if (!w.leaf.count(tet_key(ch.x))) leaves = false;
        }
        if (!all_in || !leaves) continue;
        ++cand;
        double exact = 0;
        for (std::size_t i : g) exact = std::max(exact, exact_tet_error(field, w.split[i].x));
        double used = exact;
        if (model_error) {
            used = model_error(c);
            if (!(used >= exact))  // soundness only; tightness is checked against the oracle
                out.push_back("unsound: diamond " + str(c) + ": model error " + std::to_string(used) +
                              " below the exact per-diamond error " + std::to_string(exact));
        }
        bool mergeable = true;
        for (std::size_t i : g)
            if (!(used <= eps(w.split[i].x))) mergeable = false;
        if (mergeable && out.size() < 20)
            out.push_back("not minimal: diamond " + str(c) + " (" + std::to_string(g.size()) +
                          " tets, error " + std::to_string(used) + ", e.g. tet " + str(w.split[g[0]].x) +
                          " bound " + std::to_string(eps(w.split[g[0]].x)) +
                          ") is split but all its children are leaves and merging it violates nothing");
    }
    if (checked) *checked = cand;
    return out;
}

HtHierarchy::HtHierarchy(int k_) : k(k_), L(int32_t{1} << k_) {
    const std::size_t total = level_begin(3 * k + 1);
    tets.resize(total);
    auto r = ht_roots(k);
    for (int i = 0; i < 6; ++i) tets[i] = r[i];
    for (std::size_t i = 0; i < level_begin(3 * k); ++i) {
        auto c = ht_children(tets[i]);
        tets[2 * i + 6] = c[0];
        tets[2 * i + 7] = c[1];
    }
}

float round_up_to_float(double x) {
    if (std::isinf(x) || std::isnan(x)) return static_cast<float>(x);
    float f = static_cast<float>(x);
    if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

HtOracle::HtOracle(const HtHierarchy& h, const Volume& field) : h_(h) {
    const int k = h.k;
    const int64_t N = h.L + 1;
    const Pt bmax = {static_cast<int32_t>(field.dims.x - 1), static_cast<int32_t>(field.dims.y - 1),
                     static_cast<int32_t>(field.dims.z - 1)};
    const std::size_t T = h.tets.size();
    const std::size_t unit_begin = HtHierarchy::level_begin(3 * k);
    status_.resize(T);
    for (std::size_t i = T; i-- > 0;) {
        if (i >= unit_begin) {
            status_[i] = corners_in(h.tets[i].x, bmax) ? 0 : 1;
        } else {
            uint8_t a = status_[2 * i + 6], b = status_[2 * i + 7];
            status_[i] = (a == b && a != 2) ? a : 2;
        }
    }
    auto cidx = [&](const Pt& p) { return (int64_t{p[2]} * N + p[1]) * N + p[0]; };
    derr_.assign(N * N * N, 0.0);
    forced_.assign(N * N * N, 0);
    has_inside_.assign(N * N * N, 0);
    dtets_.resize(N * N * N);
    dparents_.resize(N * N * N);
    centre_.resize(unit_begin);
    for (std::size_t i = 0; i < unit_begin; ++i) {
        const int64_t c = cidx(ht_spine_mid(h.tets[i]));
        centre_[i] = c;
        dtets_[c].push_back(static_cast<int32_t>(i));
        if (status_[i] == 0) {
            has_inside_[c] = 1;
            derr_[c] = std::max(derr_[c], exact_tet_error(field, h.tets[i].x));
        } else if (status_[i] == 2) {
            forced_[c] = 1;
        }
        if (i >= 6) {
            int32_t pc = static_cast<int32_t>(centre_[(i - 6) / 2]);
            auto& P = dparents_[c];
            if (std::find(P.begin(), P.end(), pc) == P.end()) P.push_back(pc);
        }
    }
}

OracleResult HtOracle::extract(const TetBound& eps, const DiamondErrorFn& model_error) const {
    OracleResult res;
    const std::size_t unit_begin = HtHierarchy::level_begin(3 * h_.k);
    res.diamond_error = derr_;
    res.diamond_forced = forced_;
    res.diamond_has_inside = has_inside_;
    res.split.assign(derr_.size(), 0);
    auto ok = [&](std::size_t i) {
        if (i >= unit_begin || status_[i] == 1) return true;
        if (status_[i] == 2) return false;
        const int64_t c = centre_[i];
        if (forced_[c]) return false;
        double d = derr_[c];
        if (model_error) d = model_error(ht_spine_mid(h_.tets[i]));  // centre of an inside tet is in B
        return d <= eps(h_.tets[i].x);
    };
    std::vector<std::size_t> stack;
    std::function<void(int64_t)> force = [&](int64_t c) {
        if (res.split[c]) return;
        for (int32_t p : dparents_[c]) force(p);
        res.split[c] = 1;
        for (int32_t t : dtets_[c])
            for (std::size_t ch : {2 * std::size_t(t) + 6, 2 * std::size_t(t) + 7})
                if (!ok(ch)) stack.push_back(ch);
    };
    for (std::size_t r = 0; r < 6; ++r)
        if (!ok(r)) stack.push_back(r);
    while (!stack.empty()) {
        std::size_t t = stack.back();
        stack.pop_back();
        force(centre_[t]);
    }
    std::vector<std::size_t> walk = {0, 1, 2, 3, 4, 5};
    while (!walk.empty()) {
        std::size_t t = walk.back();
        walk.pop_back();
        if (t >= unit_begin || !res.split[centre_[t]]) {
            if (status_[t] == 0) res.mesh.push_back(tet_key(h_.tets[t].x));
            continue;
        }
        walk.push_back(2 * t + 6);
        walk.push_back(2 * t + 7);
    }
    std::sort(res.mesh.begin(), res.mesh.end());
    return res;
}

OracleResult oracle_extract(const HtHierarchy& h, const Volume& field, const TetBound& eps,
                            const DiamondErrorFn& model_error) {
    return HtOracle(h, field).extract(eps, model_error);
}

}  // namespace tetlod::test
