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
    // Count first, so that every mesh is allocated once at its exact size. Records are
    // position independent: they move as bytes.
    std::vector<size_t> bytes(bricks + 1, 0);
    HandedTet t;
    for (const BrickMesh& m : from)
        for (BrickMeshReader in(m); in.next(t);) {
            const uint32_t b = brick_of(t.v, faces, dims);
            in.skip_points();
            bytes[b == kCarried ? bricks : b] += in.offset() - in.record_begin();
        }
    for (size_t b = 0; b < bricks; ++b) into[b].bytes.reserve(bytes[b]);
    carry.bytes.reserve(bytes[bricks]);
    for (BrickMesh& m : from) {
        for (BrickMeshReader in(m); in.next(t);) {
            const uint32_t b = brick_of(t.v, faces, dims);
            in.skip_points();
            (b == kCarried ? carry : into[b]).append_record(m, in.record_begin(), in.offset(), t.points);
        }
        m = BrickMesh{};
    }
}

void pin_vertices(const BrickMesh& carry, std::vector<uint8_t>& pinned) {
    std::fill(pinned.begin(), pinned.end(), uint8_t(0));
    HandedTet t;
    for (BrickMeshReader in(carry); in.next(t);)
        for (uint32_t g : t.v) pinned[g] = 1;
}

std::vector<std::array<uint32_t, 4>> tets_of(const BrickMesh& m) {
    std::vector<std::array<uint32_t, 4>> out;
    out.reserve(m.tets);
    HandedTet t;
    for (BrickMeshReader in(m); in.next(t);) out.push_back(t.v);
    return out;
}

}  // namespace tetlod::mt
