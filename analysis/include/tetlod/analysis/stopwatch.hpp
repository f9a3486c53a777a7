#pragma once
// Wall time since construction, for the times reports print (build, load,
// extraction). Steady clock: never goes backwards.
#include <chrono>

namespace tetlod {

class Stopwatch {
  public:
    Stopwatch() : start_(std::chrono::steady_clock::now()) {}
    double seconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    }

  private:
    std::chrono::steady_clock::time_point start_;
};

}  // namespace tetlod
