#pragma once
// What run_isolated (one read, one result) and IsolatedServer (a child serving
// requests) share: the forked child's setup, the page where it reports its
// exception, and how the way a child ended becomes a tetlod::Error. Private to
// tetlod_core.
#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <string>
#include <utility>

#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_process.hpp"

namespace tetlod::isolated_detail {

// Thrown by IsolatedReader; deliberately not std::exception, so a parent
// callback's catch (const std::exception&) cannot swallow them.
struct ChildEndedEarly {};
struct TimeRanOut {};

double now_seconds();

/// What the child reports when it ends with an exception: an anonymous shared
/// mapping created before fork, so the parent sees it after the child exits.
class ReportPage {
  public:
    /// Throws IoError naming `file` when the mapping cannot be made.
    explicit ReportPage(const std::string& file);
    ~ReportPage();
    ReportPage(const ReportPage&) = delete;
    ReportPage& operator=(const ReportPage&) = delete;
    void set(ErrorCode code, const std::string& message);
    /// The reported error, if the child wrote one.
    bool has_report() const;
    Error error() const;

  private:
    void* page_;
};

/// In the child, right after fork: dies with its parent, restores the crash
/// signals' defaults (so a crash ends it by its signal), caps its memory at
/// `memory_limit` (0: none), runs `body`, reports its exception in `page` and
/// _exits (status 0 when body returned). Never returns.
[[noreturn]] void child_main(const IsolatedTask& task, pid_t parent_pid, uint64_t memory_limit,
                             ReportPage& page, const std::function<void()>& body);

/// Caps the calling process's data (RLIMIT_DATA) at `bytes` beyond what it
/// holds now (0: no cap; nothing under AddressSanitizer, whose shadow counts).
void limit_data_beyond_current(uint64_t bytes);

/// Waits for the child until `deadline` (now_seconds() clock), then kills it.
/// Returns the wait status and whether it had to be killed.
std::pair<int, bool> reap(pid_t pid, double deadline);
/// SIGKILL and wait.
void kill_and_reap(pid_t pid);

/// The error for a child stopped at its time limit.
Error time_limit_error(const IsolatedTask& task);
/// Throws the error a child's end means (wait `status`, its report); returns
/// when it exited 0 and `complete` (its whole result was read).
void throw_child_end(const IsolatedTask& task, int status, const ReportPage& page, bool complete);

}  // namespace tetlod::isolated_detail
