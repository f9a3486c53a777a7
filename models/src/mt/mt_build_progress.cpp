// Progress of the bricked MT build: shares of work per brick (see mt_build_progress.hpp).
#include "mt_build_progress.hpp"

namespace tetlod::mt {

namespace {

/// Grid coordinates x in [lo, hi] free along one axis in a pass of bricks of `size`
/// cells over `cells`: not on an inner brick face (a multiple of size strictly
/// inside 0..cells). size <= 0: the pass before the first, nothing is free.
int64_t free_along(int64_t lo, int64_t hi, int64_t size, int64_t cells) {
    if (size <= 0) return 0;
    const int64_t first = (lo + size - 1) / size, last = hi / size;  // multiples of size in [lo, hi]
    int64_t frozen = last >= first ? last - first + 1 : 0;
    if (lo == 0) --frozen;                                   // 0 is a face of the volume
    if (hi == cells && cells % size == 0) --frozen;          // so is `cells`
    return (hi - lo + 1) - frozen;
}

uint64_t free_in(const BrickBox& box, int64_t size, const std::array<int64_t, 3>& cells) {
    uint64_t r = 1;
    for (int a = 0; a < 3; ++a) r *= uint64_t(free_along(box.lo[a], box.hi[a], size, cells[a]));
    return r;
}

}  // namespace

BuildProgress::BuildProgress(std::function<void(uint64_t, uint64_t)> report, std::array<int64_t, 3> cells,
                             std::vector<int64_t> sizes)
    : report_(std::move(report)), cells_(cells), sizes_(std::move(sizes)) {
    if (!report_) return;
    BrickBox whole;
    whole.hi = cells_;
    for (size_t p = 0; p < sizes_.size(); ++p) total_ += share(int(p), whole);
}

uint64_t BuildProgress::share(int pass, const BrickBox& box) const {
    uint64_t weight = 1;
    for (int p = 0; p < pass; ++p) weight *= 3;
    const uint64_t now = free_in(box, sizes_[size_t(pass)], cells_);
    const uint64_t before = pass == 0 ? 0 : free_in(box, sizes_[size_t(pass) - 1], cells_);
    return weight * (now - before);
}

void BuildProgress::start() {
    if (report_) report_(0, total_);
}

void BuildProgress::brick_done(int pass, const BrickBox& box) {
    if (!report_) return;
    const uint64_t add = share(pass, box);
    std::lock_guard<std::mutex> lock(mutex_);
    done_ += add;
    report_(done_, total_);
}

}  // namespace tetlod::mt
