// The forked child's setup and the meaning of its end, shared by run_isolated
// and IsolatedServer. See isolated_child.hpp.
#include "isolated_child.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>

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

namespace tetlod::isolated_detail {

namespace {

struct ChildReport {
    int32_t code;
    uint32_t length;
    char message[65536 - 8];
};

// Exit status of a child that wrote a ChildReport.
constexpr int kReportedExit = 77;

std::string signal_name(int sig) {
    switch (sig) {
        case SIGSEGV:
            return "SIGSEGV";
        case SIGBUS:
            return "SIGBUS";
        case SIGABRT:
            return "SIGABRT";
        case SIGFPE:
            return "SIGFPE";
        case SIGILL:
            return "SIGILL";
        case SIGKILL:
            return "SIGKILL";
        case SIGTERM:
            return "SIGTERM";
        case SIGTRAP:
            return "SIGTRAP";
        case SIGSYS:
            return "SIGSYS";
        case SIGXCPU:
            return "SIGXCPU";
        default:
            return "signal " + std::to_string(sig);
    }
}

std::string seconds_text(double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", s);
    return buf;
}

// VmData of this process from /proc/self/status, with system calls only and a
// stack buffer: it runs in a child forked from a threaded parent, where malloc's
// locks may be held by threads that do not exist. 0 when unknown.
uint64_t current_data_bytes() {
    const int fd = ::open("/proc/self/status", O_RDONLY | O_CLOEXEC);
    if (fd < 0) return 0;
    char buf[8192];
    std::size_t n = 0;
    for (ssize_t r; n < sizeof buf - 1 && (r = ::read(fd, buf + n, sizeof buf - 1 - n)) != 0;) {
        if (r < 0) {
            if (errno == EINTR) continue;
            break;
        }
        n += std::size_t(r);
    }
    ::close(fd);
    buf[n] = '\0';
    const char* at = std::strstr(buf, "VmData:");
    if (!at) return 0;
    uint64_t kb = 0;
    for (at += 7; *at == ' ' || *at == '\t'; ++at) {
    }
    for (; *at >= '0' && *at <= '9'; ++at) kb = kb * 10 + uint64_t(*at - '0');
    return kb * 1024;
}

}  // namespace

double now_seconds() {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

ReportPage::ReportPage(const std::string& file) {
    page_ = ::mmap(nullptr, sizeof(ChildReport), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS,
                   -1, 0);
    if (page_ == MAP_FAILED)
        throw Error(ErrorCode::IoError, "cannot map memory to read '" + file +
                                            "' in a child process: " + std::strerror(errno));
    static_cast<ChildReport*>(page_)->length = 0;
}

ReportPage::~ReportPage() { ::munmap(page_, sizeof(ChildReport)); }

void ReportPage::set(ErrorCode code, const std::string& message) {
    auto* r = static_cast<ChildReport*>(page_);
    r->code = static_cast<int32_t>(code);
    const std::size_t n = std::min(message.size(), sizeof r->message);
    std::memcpy(r->message, message.data(), n);
    r->length = static_cast<uint32_t>(n);
}

bool ReportPage::has_report() const { return static_cast<const ChildReport*>(page_)->length > 0; }

Error ReportPage::error() const {
    const auto* r = static_cast<const ChildReport*>(page_);
    int32_t code = r->code;
    if (code <= static_cast<int32_t>(ErrorCode::Ok) ||
        code > static_cast<int32_t>(ErrorCode::NotBuilt))
        code = static_cast<int32_t>(ErrorCode::CorruptData);
    return Error(static_cast<ErrorCode>(code),
                 std::string(r->message, std::min<std::size_t>(r->length, sizeof r->message)));
}

void limit_data_beyond_current(uint64_t bytes) {
    if (bytes == 0 || TETLOD_ASAN) return;
    const uint64_t cap = current_data_bytes() + bytes;
    const rlimit lim{rlim_t(cap), rlim_t(cap)};
    ::setrlimit(RLIMIT_DATA, &lim);
}

void child_main(const IsolatedTask& task, pid_t parent_pid, uint64_t memory_limit, ReportPage& page,
                const std::function<void()>& body) {
    // Never returns, never runs the parent's atexit handlers.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent_pid) ::_exit(kReportedExit);
    ::signal(SIGPIPE, SIG_IGN);
    // A crash in the library must end the child by its signal, so the parent
    // can name it: handlers inherited from the parent (sanitizers', libFuzzer's)
    // would turn it into an ordinary exit and, under libFuzzer, write a crash file.
    for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, SIG_DFL);
    if (memory_limit > 0 && !TETLOD_ASAN) {
        const rlimit cap{rlim_t(memory_limit), rlim_t(memory_limit)};
        ::setrlimit(RLIMIT_DATA, &cap);
    }
    const std::string file = "'" + task.file + "'";
    int status = 0;
    try {
        body();
    } catch (const Error& e) {
        page.set(e.code(), e.what());
        status = kReportedExit;
    } catch (const std::bad_alloc&) {
        page.set(ErrorCode::TooLarge, task.library + " ran out of memory reading " + file);
        status = kReportedExit;
    } catch (const std::exception& e) {
        page.set(ErrorCode::CorruptData,
                 task.library + " failed reading " + file + ": " + e.what());
        status = kReportedExit;
    } catch (...) {
        page.set(ErrorCode::CorruptData,
                 task.library + " failed reading " + file + " (unknown exception)");
        status = kReportedExit;
    }
    ::_exit(status);
}

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

void kill_and_reap(pid_t pid) {
    ::kill(pid, SIGKILL);
    int st;
    while (::waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
}

Error time_limit_error(const IsolatedTask& task) {
    return Error(ErrorCode::CorruptData, task.library + " did not finish reading '" + task.file +
                                             "' within " + seconds_text(task.time_limit_seconds) +
                                             " s and was stopped: the file is corrupt (an endless "
                                             "loop) or needs a longer time limit");
}

void throw_child_end(const IsolatedTask& task, int status, const ReportPage& page, bool complete) {
    const std::string file = "'" + task.file + "'";
    if (WIFSIGNALED(status))
        throw Error(ErrorCode::CorruptData, task.library + " crashed (" +
                                                signal_name(WTERMSIG(status)) + ") reading " +
                                                file + ": the file is corrupt");
    if (WIFEXITED(status) && WEXITSTATUS(status) == kReportedExit && page.has_report())
        throw page.error();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        throw Error(ErrorCode::CorruptData,
                    task.library + " failed reading " + file + " (exit status " +
                        std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                        "): the file is corrupt");
    if (!complete)
        throw Error(ErrorCode::CorruptData, task.library +
                                                " ended without a complete result reading " + file +
                                                ": the file is corrupt");
}

}  // namespace tetlod::isolated_detail
