#pragma once
// How `tetlod-mpi decode` cuts the volume over ranks: slabs of whole rows of
// the finest bricks. A container decodes a row of cycle-0 bricks (2^(1+b)
// planes, b = brick_log2: 32 by default) at a time (open_ht_planes), so a
// slab boundary inside a row would make both neighbours decode that row; on
// row boundaries every row is decoded by exactly one rank. Rank r holds rows
// R·r/N .. R·(r+1)/N − 1 (R rows, the last one possibly short), so with more
// ranks than rows some ranks hold no plane (they still join every collective
// write, with an empty selection).
#include <algorithm>
#include <cstdint>

namespace tetlod::mpi {

struct RowSlabs {
    int64_t planes = 0;  // of the volume (the decoded dataset's z)
    int64_t row = 1;     // planes per row of finest bricks
    int ranks = 1;

    int64_t rows() const { return (planes + row - 1) / row; }
    /// First plane of rank r's slab (planes when it holds none).
    int64_t begin(int r) const { return std::min(planes, rows() * r / ranks * row); }
    int64_t end(int r) const { return begin(r + 1); }
    int64_t count(int r) const { return end(r) - begin(r); }
    /// The most planes any rank holds.
    int64_t largest() const { return std::min(planes, (rows() + ranks - 1) / ranks * row); }
};

}  // namespace tetlod::mpi
