#pragma once
// The brick layout of the MT build's passes, and the hand-over of the mesh from one
// pass to the next (docs/mt.md §2, "Bricks").
//
// Why the faces shift: a point on a brick face is frozen for the whole pass, so it
// keeps the resolution it had when the pass began. If every pass kept faces of the
// previous one (bricks nested 2x2x2), the middle faces of the volume would stay frozen
// from the first pass to the last and every LOD below the last-but-one pass's error
// cap would carry them at full resolution. Here the faces of pass p+1 lie inside
// pass p's bricks: a face is frozen in one pass only, where the previous pass has
// already decimated its neighbourhood to that pass's cap.
//
// The price: a tet of pass p may cross a face of pass p+1. Such a tet goes to no brick;
// it is carried to the next pass whole, and its vertices are pinned (frozen) meanwhile.
#include <array>
#include <cstdint>
#include <vector>

#include "mt_decimate.hpp"

namespace tetlod::mt {

/// Brick faces of every pass for a volume of `cells` cells per axis. Pass 0: as few
/// bricks of at most `brick_cells` cells per axis as possible, of even sizes (0: one
/// brick). Each later pass has half as many bricks per axis (rounded up), of about equal
/// sizes, with faces inside the previous pass's bricks, a quarter of a brick or more
/// from their faces; the last pass is one brick.
std::vector<PassFaces> plan_brick_passes(const std::array<int64_t, 3>& cells, int64_t brick_cells);

/// Hands the meshes of one pass over to the bricks of the next one. `from`: the meshes
/// of the finished pass in brick order, then the tets carried over it (emptied as they
/// are read, so the mesh is held about once). Each tet goes to the brick of `faces`
/// whose box holds all its vertices, in the order read; the others go to `carry`.
/// `into` gets one mesh per brick (raster order). Deterministic.
void distribute_tets(std::vector<BrickMesh>& from, const PassFaces& faces, const Dims& dims,
                     std::vector<BrickMesh>& into, BrickMesh& carry);

/// Sets `pinned` (sized to the volume) to 1 exactly at the vertices of `carry`.
void pin_vertices(const BrickMesh& carry, std::vector<uint8_t>& pinned);

/// The vertices of every tet of `m`, in order (the last pass's mesh is the MT's base).
std::vector<std::array<uint32_t, 4>> tets_of(const BrickMesh& m);

}  // namespace tetlod::mt
