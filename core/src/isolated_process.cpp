// run_isolated: fork, pipe, deadline. See isolated_process.hpp for the contract.
#include "tetlod/core/isolated_process.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <new>

#include "tetlod/core/error.hpp"

// AddressSanitizer maps terabytes of shadow memory as private writable memory:
// under it, a data limit would make every allocation in the child fail.
#if defined(__SANITIZE_ADDRESS__)
#define TETLOD_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TETLOD_ASAN 1
#endif
#endif
#ifndef TETLOD_ASAN
#define TETLOD_ASAN 0
#endif

namespace tetlod {

namespace {

// Thrown by IsolatedReader; deliberately not std::exception, so a parent
// callback's catch (const std::exception&) cannot swallow them.
struct ChildEndedEarly {};
struct TimeRanOut {};

double now_seconds() {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

// What the child reports when it ends with an exception: lives in an anonymous
// shared mapping created before fork, so the parent sees it after the child exits.
struct ChildReport {
    int32_t code;
    uint32_t length;
    char message[65536 - 8];
};

// Exit status of a child that wrote a ChildReport.
constexpr int kReportedExit = 77;

void report(ChildReport* r, ErrorCode code, const std::string& message) {
    r->code = static_cast<int32_t>(code);
    const std::size_t n = std::min(message.size(), sizeof r->message);
    std::memcpy(r->message, message.data(), n);
    r->length = static_cast<uint32_t>(n);
}

std::string signal_name(int sig) {
    switch (sig) {
        case SIGSEGV: return "SIGSEGV";
        case SIGBUS: return "SIGBUS";
        case SIGABRT: return "SIGABRT";
        case SIGFPE: return "SIGFPE";
        case SIGILL: return "SIGILL";
        case SIGKILL: return "SIGKILL";
        case SIGTERM: return "SIGTERM";
        case SIGTRAP: return "SIGTRAP";
        case SIGSYS: return "SIGSYS";
        case SIGXCPU: return "SIGXCPU";
        default: return "signal " + std::to_string(sig);
    }
}

std::string seconds_text(double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", s);
    return buf;
}

// Waits for the child until the deadline; kills it if it is still running then.
// Returns the wait status and whether the child had to be killed.
std::pair<int, bool> reap(pid_t pid, double deadline) {
    int status = 0;
    for (;;) {
        pid_t r = ::waitpid(pid, &status, WNOHANG);
        if (r == pid) return {status, false};
        if (r < 0 && errno != EINTR) return {0, false};
        if (now_seconds() >= deadline) break;
        timespec pause{0, 2'000'000};
        ::nanosleep(&pause, nullptr);
    }
    ::kill(pid, SIGKILL);
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    return {status, true};
}

}  // namespace

double isolation_time_limit(const IsolationOptions& options, uint64_t input_bytes) {
    if (options.timeout_seconds > 0) return options.timeout_seconds;
    const double mib = static_cast<double>(input_bytes) / (1024.0 * 1024.0);
    return std::max(0.0, options.base_seconds) + std::max(0.0, options.seconds_per_mib) * mib;
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
    void* shared = ::mmap(nullptr, sizeof(ChildReport), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (shared == MAP_FAILED)
        throw Error(ErrorCode::IoError, "cannot map memory to read " + file + " in a child process: " +
                                            std::strerror(errno));
    struct Unmap {
        void* p;
        ~Unmap() { ::munmap(p, sizeof(ChildReport)); }
    } unmap{shared};
    auto* rep = static_cast<ChildReport*>(shared);
    rep->length = 0;

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
        // Child: never returns, never runs the parent's atexit handlers.
        ::close(fds[0]);
        ::prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (::getppid() != parent_pid) ::_exit(kReportedExit);
        ::signal(SIGPIPE, SIG_IGN);
        // A crash in the library must end the child by its signal, so the parent
        // can name it: handlers inherited from the parent (sanitizers', libFuzzer's)
        // would turn it into an ordinary exit and, under libFuzzer, write a crash file.
        for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, SIG_DFL);
        if (task.memory_limit_bytes > 0 && !TETLOD_ASAN) {
            const rlimit cap{rlim_t(task.memory_limit_bytes), rlim_t(task.memory_limit_bytes)};
            ::setrlimit(RLIMIT_DATA, &cap);
        }
        int status = 0;
        try {
            IsolatedWriter w(fds[1]);
            child(w);
        } catch (const Error& e) {
            report(rep, e.code(), e.what());
            status = kReportedExit;
        } catch (const std::bad_alloc&) {
            report(rep, ErrorCode::TooLarge, task.library + " ran out of memory reading " + file);
            status = kReportedExit;
        } catch (const std::exception& e) {
            report(rep, ErrorCode::CorruptData, task.library + " failed reading " + file + ": " + e.what());
            status = kReportedExit;
        } catch (...) {
            report(rep, ErrorCode::CorruptData, task.library + " failed reading " + file + " (unknown exception)");
            status = kReportedExit;
        }
        ::_exit(status);
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
        ::kill(pid, SIGKILL);
        int st;
        while (::waitpid(pid, &st, 0) < 0 && errno == EINTR) {
        }
        throw;
    }
    if (timed_out) ::kill(pid, SIGKILL);
    auto [status, killed] = reap(pid, timed_out ? now_seconds() : deadline);
    if (timed_out || (killed && !complete))
        throw Error(ErrorCode::CorruptData,
                    task.library + " did not finish reading " + file + " within " +
                        seconds_text(task.time_limit_seconds) +
                        " s and was stopped: the file is corrupt (an endless loop) or needs a longer time limit");
    if (WIFSIGNALED(status))
        throw Error(ErrorCode::CorruptData, task.library + " crashed (" + signal_name(WTERMSIG(status)) +
                                                ") reading " + file + ": the file is corrupt");
    if (WIFEXITED(status) && WEXITSTATUS(status) == kReportedExit && rep->length > 0) {
        int32_t code = rep->code;
        if (code <= static_cast<int32_t>(ErrorCode::Ok) || code > static_cast<int32_t>(ErrorCode::NotBuilt))
            code = static_cast<int32_t>(ErrorCode::CorruptData);
        throw Error(static_cast<ErrorCode>(code),
                    std::string(rep->message, std::min<std::size_t>(rep->length, sizeof rep->message)));
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        throw Error(ErrorCode::CorruptData, task.library + " failed reading " + file + " (exit status " +
                                                std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                                                "): the file is corrupt");
    if (!complete)
        throw Error(ErrorCode::CorruptData,
                    task.library + " ended without a complete result reading " + file + ": the file is corrupt");
}

}  // namespace tetlod
