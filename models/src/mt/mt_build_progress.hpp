#pragma once
// Progress of the bricked MT build (MtBuildOptions::progress). The unit of work is a
// grid point becoming free to collapse: every point becomes free in exactly one pass
// (pass 0 for the points off the inner faces of its bricks, a later pass for the faces
// it unfreezes), so the total is known before the first brick starts and the sum of
// the bricks' shares reaches it exactly. A collapse costs more in later passes (the
// tets are larger, and the last pass runs on one thread): on bucky 128^3 and neghip,
// 2 threads, the wall time per collapse grew about threefold per pass, so a point
// first free in pass p weighs 3^p. Only whole bricks are reported: the decimation
// loop (mt_decimate.cpp) is left without a hook, so the last pass, one brick, shows
// as a single step.
#include <array>
#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

#include "mt_decimate.hpp"

namespace tetlod::mt {

class BuildProgress {
public:
    /// `cells`: cells per axis; `passes`: the brick faces of each pass, first to last
    /// (the last pass holds one brick). `report` may be empty (then nothing is done).
    BuildProgress(std::function<void(uint64_t, uint64_t)> report, std::array<int64_t, 3> cells,
                  std::vector<PassFaces> passes);
    /// Reports (0, total).
    void start();
    /// A brick of pass `pass` is done. Callable from any thread: calls are serialized
    /// and `done` never decreases; the last brick of the last pass gives done == total.
    void brick_done(int pass, const BrickBox& box);
    uint64_t total() const { return total_; }

private:
    /// Weighted points of `box` that pass `pass` frees (free now, frozen in pass - 1).
    uint64_t share(int pass, const BrickBox& box) const;

    std::function<void(uint64_t, uint64_t)> report_;
    std::array<int64_t, 3> cells_;
    std::vector<PassFaces> passes_;
    uint64_t total_ = 0, done_ = 0;
    std::mutex mutex_;
};

}  // namespace tetlod::mt
