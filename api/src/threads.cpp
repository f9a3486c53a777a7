// ThreadLimit over oneTBB's global_control (see threads.hpp).
#include "tetlod/threads.hpp"

#include <tbb/global_control.h>

#include <string>

#include "tetlod/core/error.hpp"

namespace tetlod {

struct ThreadLimit::Control {
    explicit Control(int n) : limit(tbb::global_control::max_allowed_parallelism, std::size_t(n)) {}
    tbb::global_control limit;
};

ThreadLimit::ThreadLimit(int threads) {
    if (threads < 0)
        throw Error(ErrorCode::InvalidArgument, "threads " + std::to_string(threads) + ": expected 0 (all) or more");
    if (threads > 0) control_ = std::make_unique<Control>(threads);
}

ThreadLimit::~ThreadLimit() = default;

int active_threads() {
    return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace tetlod
