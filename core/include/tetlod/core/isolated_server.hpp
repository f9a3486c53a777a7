#pragma once
// A persistent isolated child: run_isolated's protection (crash, hang, memory
// limit -> tetlod::Error naming the file) for a reader that answers many
// requests, so a file is opened once and read piece by piece (plane requests
// of out-of-core conversion) rather than sent back whole.
//
// The child runs `serve` once: it typically opens the file, answers the first
// (empty) request with a header, then loops on requests.next() until it returns
// false (the server was destroyed). Every call() has its own time limit. A
// child that crashes, exits, or runs past a call's time limit (it is killed)
// ends the server: that call and every later one throw the same Error, with
// run_isolated's codes and messages. An exception thrown by the parent's reply
// callback (validating what the child sent) kills the child and propagates.
// The destructor kills and reaps the child.
//
// The child dies with the thread that created the server (PR_SET_PDEATHSIG
// follows the thread): create it on a thread that outlives it. Calls are not
// thread-safe (one request at a time).
#include <sys/types.h>

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>

#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_process.hpp"

namespace tetlod {

namespace isolated_detail {
class ReportPage;
}

/// The child's end of the request channel.
class IsolatedRequests {
  public:
    explicit IsolatedRequests(int fd) : fd_(fd) {}
    /// Reads exactly `size` bytes of the next request, waiting as long as it
    /// takes. False when the parent closed the channel before its first byte
    /// (serve should return); a request cut short throws IoError.
    bool next(void* data, std::size_t size);

  private:
    int fd_;
};

class IsolatedServer {
  public:
    using Serve = std::function<void(IsolatedRequests& requests, IsolatedWriter& replies)>;
    /// Forks the child (task.memory_limit_bytes caps its data beyond what the
    /// process holds when it forks; 0: none). Throws IoError when it cannot.
    IsolatedServer(const IsolatedTask& task, const Serve& serve);
    ~IsolatedServer();
    IsolatedServer(const IsolatedServer&) = delete;
    IsolatedServer& operator=(const IsolatedServer&) = delete;

    /// Sends `size` bytes of request (none: just read what the child sends
    /// next) and runs `reply` on the answer, all within `time_limit_seconds`.
    void call(const void* request, std::size_t size, double time_limit_seconds,
              const std::function<void(IsolatedReader&)>& reply);

    const IsolatedTask& task() const { return task_; }

  private:
    [[noreturn]] void fail(const Error& e);
    void stop();

    IsolatedTask task_;
    std::unique_ptr<isolated_detail::ReportPage> page_;
    int fd_ = -1;
    pid_t pid_ = -1;
    std::optional<Error> failed_;
};

}  // namespace tetlod
