// Progress of the bricked MT build: shares of work per brick (see mt_build_progress.hpp).
#include "mt_build_progress.hpp"

namespace tetlod::mt {

namespace {

/// Grid coordinates x in [lo, hi] free along one axis in a pass with these brick
/// faces: not on an inner face (the first and last faces are the volume's).
int64_t free_along(int64_t lo, int64_t hi, const std::vector<int64_t>& faces) {
    int64_t frozen = 0;
    for (size_t i = 1; i + 1 < faces.size(); ++i) frozen += faces[i] >= lo && faces[i] <= hi;
    return (hi - lo + 1) - frozen;
}

uint64_t free_in(const BrickBox& box, const PassFaces& faces) {
    uint64_t r = 1;
    for (int a = 0; a < 3; ++a) r *= uint64_t(free_along(box.lo[a], box.hi[a], faces[size_t(a)]));
    return r;
}

}  // namespace

BuildProgress::BuildProgress(std::function<void(uint64_t, uint64_t)> report, std::array<int64_t, 3> cells,
                             std::vector<PassFaces> passes)
    : report_(std::move(report)), cells_(cells), passes_(std::move(passes)) {
    if (!report_) return;
    BrickBox whole;
    whole.hi = cells_;
    for (size_t p = 0; p < passes_.size(); ++p) total_ += share(int(p), whole);
}

uint64_t BuildProgress::share(int pass, const BrickBox& box) const {
    uint64_t weight = 1;
    for (int p = 0; p < pass; ++p) weight *= 3;
    const uint64_t now = free_in(box, passes_[size_t(pass)]);
    const uint64_t before = pass == 0 ? 0 : free_in(box, passes_[size_t(pass) - 1]);
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
