#pragma once
// Progress of the bricked MT build (MtBuildOptions::progress). The unit of work is a
// grid point of a brick's box: a brick's share is the points of its box, so the total
// (every pass's bricks) is known before the first brick starts and the sum of the
// shares reaches it exactly. Every pass weighs about the same: the later passes hold
// fewer points (the earlier ones decimated up to their error caps) but their collapses
// cost more (larger tets, fewer bricks in parallel); iron 68^3 with the default caps,
// 2 threads: 8.6, 3.6 and 4.0 s for its three passes. Inside a brick the share advances with
// its collapses over its free vertices at the start (an upper bound of the collapses,
// close for the last pass, which removes nearly every one), so the last pass, one
// brick, moves too; the rest of a brick's share comes when it is done.
#include <array>
#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

#include "mt_decimate.hpp"

namespace tetlod::mt {

class BuildProgress {
public:
    /// `passes`: the brick faces of each pass, first to last
    /// (the last pass holds one brick). `report` may be empty (then nothing is done).
    BuildProgress(std::function<void(uint64_t, uint64_t)> report, std::vector<PassFaces> passes);
    /// Reports (0, total).
    void start();
    /// A brick of pass `pass` has done about `fraction` (0..1) of its work; `reported`
    /// is the brick's share reported so far (the caller keeps it per brick, 0 at first).
    void brick_part(int pass, const BrickBox& box, double fraction, uint64_t& reported);
    /// A brick of pass `pass` is done (`reported`: from brick_part, or 0). Callable
    /// from any thread: calls are serialized and `done` never decreases; the last brick
    /// of the last pass gives done == total.
    void brick_done(int pass, const BrickBox& box, uint64_t reported = 0);
    uint64_t total() const { return total_; }

private:
    /// The points of `box` (any pass).
    uint64_t share(int pass, const BrickBox& box) const;

    std::function<void(uint64_t, uint64_t)> report_;
    std::vector<PassFaces> passes_;
    uint64_t total_ = 0, done_ = 0;
    std::mutex mutex_;
};

}  // namespace tetlod::mt
