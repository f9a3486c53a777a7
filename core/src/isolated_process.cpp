// run_isolated: fork, pipe, deadline. See isolated_process.hpp for the contract;
// the child's setup and the meaning of its end are in isolated_child.cpp.
#include "tetlod/core/isolated_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <new>

#include "isolated_child.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

using namespace isolated_detail;

namespace {
// The default limit is there to stop hangs, not slow reads. Under AddressSanitizer
// (and the fuzzers' coverage instrumentation) the readers' own code runs several
// times slower: a 0.7 MB .vdb that reads in a fraction of a second took over the
// 11.3 s it is allowed there, under a loaded 2-core CI. An explicit timeout_seconds
// is never scaled.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TETLOD_INSTRUMENTED_BUILD 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(TETLOD_SANITIZED)
#define TETLOD_INSTRUMENTED_BUILD 1
#endif
#ifdef TETLOD_INSTRUMENTED_BUILD
constexpr double kDefaultLimitScale = 5;
#else
constexpr double kDefaultLimitScale = 1;
#endif
}  // namespace

double isolation_time_limit(const IsolationOptions& options, uint64_t input_bytes) {
    if (options.timeout_seconds > 0) return options.timeout_seconds;
    const double mib = static_cast<double>(input_bytes) / (1024.0 * 1024.0);
    return kDefaultLimitScale * (std::max(0.0, options.base_seconds) + std::max(0.0, options.seconds_per_mib) * mib);
}

uint64_t isolation_memory_limit(const IsolationOptions& options, uint64_t input_bytes) {
    if (options.memory_limit_bytes > 0) return options.memory_limit_bytes;
    const double limit = double(options.memory_base_bytes) + options.memory_per_input_byte * double(input_bytes);
    return limit >= 1.8e19 ? 0 : uint64_t(limit);
}

void IsolatedWriter::write(const void* data, std::size_t size) {
    const char* p = static_cast<const char*>(data);
    while (size > 0) {
        ssize_t n = ::write(fd_, p, size);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw Error(ErrorCode::IoError, "the reading process lost its parent");
        p += n;
        size -= static_cast<std::size_t>(n);
    }
}

void IsolatedReader::read(void* data, std::size_t size) {
    char* p = static_cast<char*>(data);
    while (size > 0) {
        const double left = deadline_ - now_seconds();
        if (left <= 0) throw TimeRanOut{};
        pollfd pfd{fd_, POLLIN, 0};
        const int ms = static_cast<int>(std::min(left * 1000.0 + 1.0, 1e9));
        int r = ::poll(&pfd, 1, ms);
        if (r < 0 && errno == EINTR) continue;
        if (r == 0) continue;  // re-check the deadline
        ssize_t n = ::read(fd_, p, size);
        if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (n <= 0) throw ChildEndedEarly{};
        p += n;
        size -= static_cast<std::size_t>(n);
    }
}

bool IsolatedReader::at_end() {
    char c;
    try {
        read(&c, 1);
    } catch (const ChildEndedEarly&) {
        return true;
    }
    return false;
}

void run_isolated(const IsolatedTask& task, const std::function<void(IsolatedWriter&)>& child,
                  const std::function<void(IsolatedReader&)>& parent) {
    const std::string file = "'" + task.file + "'";
    ReportPage page(task.file);
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0)
        throw Error(ErrorCode::IoError, "cannot create a pipe to read " + file + ": " + std::strerror(errno));
    const pid_t parent_pid = ::getpid();
    const double deadline = now_seconds() + task.time_limit_seconds;
    const pid_t pid = ::fork();
    if (pid < 0) {
        const int err = errno;
        ::close(fds[0]);
        ::close(fds[1]);
        throw Error(ErrorCode::IoError, "cannot start a process to read " + file + ": " + std::strerror(err) +
                                            " (reading without isolation is an option)");
    }
    if (pid == 0) {
        ::close(fds[0]);
        child_main(task, parent_pid, task.memory_limit_bytes, page, [&] {
            IsolatedWriter w(fds[1]);
            child(w);
        });
    }

    ::close(fds[1]);
    struct Close {
        int fd;
        ~Close() { ::close(fd); }
    } close_read{fds[0]};
    IsolatedReader reader(fds[0], deadline);
    bool complete = false, timed_out = false;
    try {
        parent(reader);
        complete = true;
        // Anything after the result is ignored; wait for the child to close its end.
        while (!reader.at_end()) {
        }
    } catch (const ChildEndedEarly&) {
    } catch (const TimeRanOut&) {
        timed_out = true;
    } catch (...) {
        kill_and_reap(pid);
        throw;
    }
    if (timed_out) ::kill(pid, SIGKILL);
    auto [status, killed] = reap(pid, timed_out ? now_seconds() : deadline);
    if (timed_out || (killed && !complete)) throw time_limit_error(task);
    throw_child_end(task, status, page, complete);
}

}  // namespace tetlod
