// Progress of the bricked MT build: shares of work per brick (see mt_build_progress.hpp).
#include "mt_build_progress.hpp"

#include <algorithm>

namespace tetlod::mt {

BuildProgress::BuildProgress(std::function<void(uint64_t, uint64_t)> report, std::vector<PassFaces> passes)
    : report_(std::move(report)), passes_(std::move(passes)) {
    if (!report_) return;
    for (const PassFaces& faces : passes_) {
        uint64_t points = 1;  // every brick's points, shared faces once per brick
        for (const auto& f : faces) {
            uint64_t along = 0;
            for (size_t i = 0; i + 1 < f.size(); ++i) along += uint64_t(f[i + 1] - f[i] + 1);
            points *= along;
        }
        total_ += points;
    }
}

uint64_t BuildProgress::share(int, const BrickBox& box) const {
    uint64_t points = 1;
    for (int a = 0; a < 3; ++a) points *= uint64_t(box.hi[a] - box.lo[a] + 1);
    return points;
}

void BuildProgress::start() {
    if (report_) report_(0, total_);
}

void BuildProgress::brick_part(int pass, const BrickBox& box, double fraction, uint64_t& reported) {
    if (!report_) return;
    const uint64_t whole = share(pass, box);
    const uint64_t now = std::min(whole, uint64_t(double(whole) * std::clamp(fraction, 0.0, 1.0)));
    if (now <= reported) return;
    const uint64_t add = now - reported;
    reported = now;
    std::lock_guard<std::mutex> lock(mutex_);
    done_ += add;
    report_(done_, total_);
}

void BuildProgress::brick_done(int pass, const BrickBox& box, uint64_t reported) {
    if (!report_) return;
    const uint64_t add = share(pass, box) - reported;
    std::lock_guard<std::mutex> lock(mutex_);
    done_ += add;
    report_(done_, total_);
}

}  // namespace tetlod::mt
