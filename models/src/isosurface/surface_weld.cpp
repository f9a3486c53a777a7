// Welding and degenerate-face removal for marching-tetrahedra surfaces. Why:
// a sample exactly equal to the isovalue puts the surface vertices of all its
// crossed edges on that sample, so the raw surface has coincident vertices and
// zero-area faces, which gmsh reports as duplicates and OpenMesh as complex
// vertices. Everything here is exact (bit-equal positions, combinatorial
// tests): no tolerance can merge two vertices that are really distinct.
#include "surface_weld.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <numeric>
#include <unordered_map>

namespace tetlod::detail {

namespace {

constexpr double kSplitShift = 1e-3;

struct PositionKey {
    std::array<double, 3> p;
    uint16_t surface;
    bool operator==(const PositionKey& o) const { return p == o.p && surface == o.surface; }
};

struct PositionHash {
    std::size_t operator()(const PositionKey& k) const {
        uint64_t h = k.surface;
        for (double d : k.p) {
            uint64_t bits;
            std::memcpy(&bits, &d, sizeof bits);
            h = (h ^ bits) * 0x9E3779B97F4A7C15ull;
            h ^= h >> 29;
        }
        return std::size_t(h);
    }
};

struct TriKey {
    std::array<uint32_t, 3> v;  // sorted
    bool operator==(const TriKey& o) const { return v == o.v; }
};
struct TriHash {
    std::size_t operator()(const TriKey& k) const {
        uint64_t h = 0;
        for (uint32_t x : k.v) h = (h ^ x) * 0x9E3779B97F4A7C15ull, h ^= h >> 31;
        return std::size_t(h);
    }
};

// +1 or -1: the parity of the rotation that sorts face f (all three distinct).
int parity(const std::array<uint32_t, 3>& f) {
    // A cyclic rotation keeps the orientation; the sorted order is one of the
    // three rotations of (f0 f1 f2) or of (f0 f2 f1).
    const uint32_t m = std::min({f[0], f[1], f[2]});
    const int i = f[0] == m ? 0 : f[1] == m ? 1 : 2;
    return f[(i + 1) % 3] < f[(i + 2) % 3] ? 1 : -1;
}

struct Find {
    std::vector<uint32_t> up;
    explicit Find(std::size_t n) : up(n) { std::iota(up.begin(), up.end(), 0u); }
    uint32_t root(uint32_t x) {
        while (up[x] != x) x = up[x] = up[up[x]];
        return x;
    }
    void join(uint32_t a, uint32_t b) { up[root(a)] = root(b); }
};

void keep_faces(TriangleMesh& m, const std::vector<char>& keep) {
    std::size_t w = 0;
    for (std::size_t i = 0; i < m.faces.size(); ++i) {
        if (!keep[i]) continue;
        m.faces[w] = m.faces[i];
        if (!m.face_error.empty()) m.face_error[w] = m.face_error[i];
        if (!m.face_surface.empty()) m.face_surface[w] = m.face_surface[i];
        ++w;
    }
    m.faces.resize(w);
    if (!m.face_error.empty()) m.face_error.resize(w);
    if (!m.face_surface.empty()) m.face_surface.resize(w);
}

uint32_t copy_vertex(RawSurface& s, uint32_t v) {
    const uint32_t c = uint32_t(s.mesh.points.size());
    s.mesh.points.push_back(s.mesh.points[v]);
    s.mesh.gradients.push_back(s.mesh.gradients[v]);
    s.weight.push_back(s.weight[v]);
    s.vertex_surface.push_back(s.vertex_surface[v]);
    return c;
}

}  // namespace

void weld_surface(RawSurface s, IsosurfaceStats& stats) {
    TriangleMesh& m = s.mesh;
    const std::size_t n = m.points.size();

    // (1) One vertex per exact position and surface; gradient sums add up.
    std::vector<uint32_t> rep(n);
    {
        std::unordered_map<PositionKey, uint32_t, PositionHash> first;
        first.reserve(n);
        for (uint32_t v = 0; v < n; ++v) {
            auto p = m.points[v];
            for (double& c : p) c += 0.0;  // -0 and +0 are the same position
            auto [it, fresh] = first.try_emplace(PositionKey{p, s.vertex_surface[v]}, v);
            rep[v] = it->second;
            if (!fresh) {
                ++stats.welded_vertices;
                for (int k = 0; k < 3; ++k) m.gradients[it->second][k] += m.gradients[v][k];
                s.weight[it->second] += s.weight[v];
            }
        }
    }
    for (auto& f : m.faces)
        for (auto& v : f) v = rep[v];

    // (2) and (3): zero-area faces and two-sided sheets.
    std::vector<char> keep(m.faces.size(), 1);
    {
        std::unordered_map<TriKey, std::vector<uint32_t>, TriHash> same;
        for (uint32_t i = 0; i < m.faces.size(); ++i) {
            auto f = m.faces[i];
            if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
                keep[i] = 0;
                ++stats.degenerate_faces;
                continue;
            }
            std::sort(f.begin(), f.end());
            same[TriKey{f}].push_back(i);
        }
        for (auto& [key, ids] : same) {
            if (ids.size() < 2) continue;
            std::vector<uint32_t> plus, minus;
            for (uint32_t i : ids) (parity(m.faces[i]) > 0 ? plus : minus).push_back(i);
            const std::size_t pairs = std::min(plus.size(), minus.size());
            for (std::size_t k = 0; k < pairs; ++k) keep[plus[k]] = keep[minus[k]] = 0;
            stats.cancelled_faces += 2 * pairs;
        }
    }
    keep_faces(m, keep);

    // (4) One vertex per fan: faces around v are joined when they share an
    // edge (v, w) that no other face uses; each extra group gets its own copy
    // of v. An edge in more than two faces (two sheets meeting along an edge
    // between samples equal to V) joins nothing, so its ends split per sheet
    // and the edge becomes one edge per sheet.
    std::unordered_map<uint64_t, uint32_t> edge_uses;
    auto edge_key = [](uint32_t a, uint32_t b) {
        return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
    };
    for (const auto& f : m.faces)
        for (int k = 0; k < 3; ++k) ++edge_uses[edge_key(f[k], f[(k + 1) % 3])];
    {
        std::vector<uint32_t> start(m.points.size() + 1, 0), incident;
        for (const auto& f : m.faces)
            for (uint32_t v : f) ++start[v + 1];
        std::partial_sum(start.begin(), start.end(), start.begin());
        incident.resize(start.back());
        std::vector<uint32_t> fill(start.begin(), start.end() - 1);
        for (uint32_t i = 0; i < m.faces.size(); ++i)
            for (uint32_t v : m.faces[i]) incident[fill[v]++] = i;
        const std::size_t before = m.points.size();
        for (uint32_t v = 0; v < before; ++v) {
            const uint32_t b = start[v], e = start[v + 1];
            if (e - b < 2) continue;
            Find groups(e - b);
            std::unordered_map<uint32_t, uint32_t> via;  // neighbour w -> a local face using (v, w)
            for (uint32_t k = b; k < e; ++k)
                for (uint32_t w : m.faces[incident[k]]) {
                    if (w == v || edge_uses[edge_key(v, w)] > 2) continue;
                    auto [it, fresh] = via.try_emplace(w, k - b);
                    if (!fresh) groups.join(k - b, it->second);
                }
            std::unordered_map<uint32_t, uint32_t> copy_of_group;  // root -> vertex id
            std::unordered_map<uint32_t, std::array<double, 4>> centroid;  // root -> sum, count
            for (uint32_t k = b; k < e; ++k) {
                const uint32_t g = groups.root(k - b);
                auto& c = centroid[g];
                for (uint32_t w : m.faces[incident[k]])
                    if (w != v) {
                        for (int d = 0; d < 3; ++d) c[d] += m.points[w][d];
                        c[3] += 1;
                    }
            }
            if (centroid.size() < 2) continue;
            const std::array<double, 3> at = m.points[v];
            for (uint32_t k = b; k < e; ++k) {
                const uint32_t g = groups.root(k - b);
                auto [it, fresh] = copy_of_group.try_emplace(g, v);
                if (fresh && copy_of_group.size() > 1) {
                    it->second = copy_vertex(s, v);
                    ++stats.split_vertices;
                }
                for (auto& x : m.faces[incident[k]])
                    if (x == v) x = it->second;
            }
            // Each fan's vertex moves 1/1000 of the way towards the mean of its
            // fan's other vertices, so the copies do not coincide (readers such
            // as gmsh take coincident vertices for duplicates): the fans are
            // separated, as lowering V by a tiny amount would separate them.
            for (const auto& [g, id] : copy_of_group) {
                const auto& c = centroid[g];
                for (int d = 0; d < 3; ++d)
                    m.points[id][d] = at[d] + kSplitShift * (c[d] / c[3] - at[d]);
            }
        }
    }

    edge_uses.clear();
    for (const auto& f : m.faces)
        for (int k = 0; k < 3; ++k) ++edge_uses[edge_key(f[k], f[(k + 1) % 3])];
    for (const auto& [e, n] : edge_uses) stats.nonmanifold_edges += n > 2;

    // (5) Drop unused vertices, keeping the order of the rest.
    std::vector<uint32_t> remap(m.points.size(), UINT32_MAX);
    for (const auto& f : m.faces)
        for (uint32_t v : f) remap[v] = 0;
    uint32_t next = 0;
    for (std::size_t v = 0; v < m.points.size(); ++v) {
        if (remap[v] == UINT32_MAX) continue;
        remap[v] = next;
        m.points[next] = m.points[v];
        m.gradients[next] = m.gradients[v];
        s.weight[next] = s.weight[v];
        s.vertex_surface[next] = s.vertex_surface[v];
        ++next;
    }
    m.points.resize(next);
    m.gradients.resize(next);
    s.weight.resize(next);
    s.vertex_surface.resize(next);
    for (auto& f : m.faces)
        for (auto& v : f) v = remap[v];
}

}  // namespace tetlod::detail
