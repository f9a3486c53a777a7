// Brick layout of the MT build's passes and the hand-over between passes (see
// mt_brick_passes.hpp for why the faces shift).
#include "mt_brick_passes.hpp"

#include <algorithm>

namespace tetlod::mt {

namespace {

constexpr uint32_t kCarried = 0xFFFFFFFFu;

/// Brick of `faces` (raster index) whose box holds the tet, or kCarried.
uint32_t brick_of(const std::array<uint32_t, 4>& tet, const PassFaces& faces, const Dims& dims) {
    std::array<int64_t, 3> lo{dims.x, dims.y, dims.z}, hi{-1, -1, -1};
    for (uint32_t g : tet) {
        const int64_t x = g % dims.x, r = g / dims.x;
        const std::array<int64_t, 3> c{x, r % dims.y, r / dims.y};
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
    }
    uint32_t index = 0, stride = 1;
    for (int a = 0; a < 3; ++a) {
        const std::vector<int64_t>& f = faces[size_t(a)];
        const size_t count = f.size() - 1;
        // The last face at or below lo (a tet has extent on every axis, so lo < the far face).
        size_t i = size_t(std::upper_bound(f.begin(), f.end(), lo[a]) - f.begin()) - 1;
        i = std::min(i, count - 1);
        if (hi[a] > f[i + 1]) return kCarried;
        index += uint32_t(i) * stride;
        stride *= uint32_t(count);
    }
    return index;
}

void append_tet(BrickMesh& into, const BrickMesh& from, size_t t) {
    if (into.point_start.empty()) into.point_start.push_back(0);
    into.tets.push_back(from.tets[t]);
    into.err.push_back(from.err[t]);
    into.face_err.push_back(from.face_err[t]);
    into.points.insert(into.points.end(), from.points.begin() + from.point_start[t],
                       from.points.begin() + from.point_start[t + 1]);
    into.point_start.push_back(uint32_t(into.points.size()));
}

}  // namespace

std::vector<PassFaces> plan_brick_passes(const std::array<int64_t, 3>& cells, int64_t brick_cells) {
    std::vector<PassFaces> passes(1);
    for (int a = 0; a < 3; ++a) {
        // Even sizes: 67 cells are 22, 22, 23, not 32 + 32 + 3 (a remainder brick of a few
        // cells would leave its neighbour alone in the next pass).
        const int64_t count = brick_cells == 0 ? 1 : std::max<int64_t>(1, (cells[a] + brick_cells - 1) / brick_cells);
        for (int64_t i = 0; i <= count; ++i) passes[0][size_t(a)].push_back(i * cells[a] / count);
    }
    while (std::any_of(passes.back().begin(), passes.back().end(), [](const auto& f) { return f.size() > 2; })) {
        PassFaces next;
        for (int a = 0; a < 3; ++a) {
            const std::vector<int64_t>& f = passes.back()[size_t(a)];
            const size_t count = f.size() - 1;
            std::vector<int64_t>& g = next[size_t(a)];
            // Half as many bricks (rounded up), of equal sizes, except that a face stays at
            // least a quarter of an old brick away from the old faces: 4 old bricks become
            // 1.75 + 2.25, not 2 + 2 (an old face frozen again) nor 1.5 + 2.5 (midpoints).
            const size_t bricks = count <= 2 ? 1 : (count + 1) / 2;
            g.push_back(f.front());
            for (size_t j = 1; j < bricks; ++j) {
                int64_t x = f.front() + int64_t(j) * (f.back() - f.front()) / int64_t(bricks);
                const size_t i = std::min(count - 1, size_t(std::upper_bound(f.begin(), f.end(), x) - f.begin()) - 1);
                const int64_t quarter = std::max<int64_t>(1, (f[i + 1] - f[i]) / 4);
                x = std::clamp(x, f[i] + quarter, std::max(f[i] + quarter, f[i + 1] - quarter));
                if (x > g.back() && x < f.back()) g.push_back(x);
            }
            g.push_back(f.back());
        }
        passes.push_back(std::move(next));
    }
    return passes;
}

void distribute_tets(std::vector<BrickMesh>& from, const PassFaces& faces, const Dims& dims,
                     std::vector<BrickMesh>& into, BrickMesh& carry) {
    size_t bricks = 1;
    for (const auto& f : faces) bricks *= f.size() - 1;
    into.assign(bricks, BrickMesh{});
    carry = BrickMesh{};
    // Count first, so that every mesh is allocated once at its exact size.
    std::vector<size_t> tets(bricks + 1, 0), points(bricks + 1, 0);
    for (const BrickMesh& m : from)
        for (size_t t = 0; t < m.tets.size(); ++t) {
            const uint32_t b = brick_of(m.tets[t], faces, dims);
            const size_t slot = b == kCarried ? bricks : b;
            ++tets[slot];
            points[slot] += m.point_start[t + 1] - m.point_start[t];
        }
    auto reserve = [&](BrickMesh& m, size_t slot) {
        m.tets.reserve(tets[slot]);
        m.err.reserve(tets[slot]);
        m.face_err.reserve(tets[slot]);
        m.point_start.reserve(tets[slot] + 1);
        m.points.reserve(points[slot]);
    };
    for (size_t b = 0; b < bricks; ++b) reserve(into[b], b);
    reserve(carry, bricks);
    for (BrickMesh& m : from) {
        for (size_t t = 0; t < m.tets.size(); ++t) {
            const uint32_t b = brick_of(m.tets[t], faces, dims);
            append_tet(b == kCarried ? carry : into[b], m, t);
        }
        m = BrickMesh{};
    }
}

void pin_vertices(const BrickMesh& carry, std::vector<uint8_t>& pinned) {
    std::fill(pinned.begin(), pinned.end(), uint8_t(0));
    for (const auto& t : carry.tets)
        for (uint32_t g : t) pinned[g] = 1;
}

}  // namespace tetlod::mt
