#pragma once
// How many threads tetlod's parallel steps (HT build and extraction, encoding,
// decoding) may use. Every result is the same for any thread count: only the
// time changes.
#include <memory>

namespace tetlod {

/// While alive, tetlod uses at most `threads` worker threads in this process
/// (threads >= 1; 0 means no limit: all cores). Nested limits: the innermost
/// wins until it ends. InvalidArgument for a negative count.
class ThreadLimit {
public:
    explicit ThreadLimit(int threads);
    ~ThreadLimit();
    ThreadLimit(const ThreadLimit&) = delete;
    ThreadLimit& operator=(const ThreadLimit&) = delete;

private:
    struct Control;
    std::unique_ptr<Control> control_;
};

/// The number of threads parallel steps use now (the active limit, else the cores).
int active_threads();

}  // namespace tetlod
