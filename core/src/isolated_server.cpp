// IsolatedServer: a forked child answering requests over a socket pair. See
// isolated_server.hpp; the child's setup and end are shared with run_isolated
// (isolated_child.cpp).
#include "tetlod/core/isolated_server.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "isolated_child.hpp"

namespace tetlod {

using namespace isolated_detail;

bool IsolatedRequests::next(void* data, std::size_t size) {
    char* p = static_cast<char*>(data);
    std::size_t got = 0;
    while (got < size) {
        const ssize_t n = ::read(fd_, p + got, size - got);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            if (got == 0) return false;
            throw Error(ErrorCode::IoError, "a request to the reading process was cut short");
        }
        got += std::size_t(n);
    }
    return true;
}

IsolatedServer::IsolatedServer(const IsolatedTask& task, const Serve& serve)
    : task_(task), page_(std::make_unique<ReportPage>(task.file)) {
    const std::string file = "'" + task.file + "'";
    int sv[2];
    // A socket pair, not pipes: the parent sends with MSG_NOSIGNAL, so a dead
    // child is an error and never a SIGPIPE in the parent.
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
        throw Error(ErrorCode::IoError,
                    "cannot create a channel to read " + file + ": " + std::strerror(errno));
    const pid_t parent_pid = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
        const int err = errno;
        ::close(sv[0]);
        ::close(sv[1]);
        throw Error(ErrorCode::IoError, "cannot start a process to read " + file + ": " +
                                            std::strerror(err) +
                                            " (reading without isolation is an option)");
    }
    if (pid == 0) {
        ::close(sv[0]);
        child_main(task, parent_pid, 0, *page_, [&] {
            limit_data_beyond_current(task.memory_limit_bytes);
            IsolatedRequests requests(sv[1]);
            IsolatedWriter replies(sv[1]);
            serve(requests, replies);
        });
    }
    ::close(sv[1]);
    fd_ = sv[0];
    pid_ = pid;
}

IsolatedServer::~IsolatedServer() { stop(); }

void IsolatedServer::stop() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    if (pid_ > 0) kill_and_reap(pid_);
    pid_ = -1;
}

void IsolatedServer::fail(const Error& e) {
    stop();
    failed_ = e;
    throw e;
}

void IsolatedServer::call(const void* request, std::size_t size, double time_limit_seconds,
                          const std::function<void(IsolatedReader&)>& reply) {
    if (failed_) throw *failed_;
    IsolatedTask t = task_;
    t.time_limit_seconds = time_limit_seconds;
    const double deadline = now_seconds() + time_limit_seconds;
    try {
        const char* p = static_cast<const char*>(request);
        while (size > 0) {
            const ssize_t n = ::send(fd_, p, size, MSG_NOSIGNAL);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) throw ChildEndedEarly{};  // EPIPE: the child is gone
            p += n;
            size -= std::size_t(n);
        }
        IsolatedReader r(fd_, deadline);
        reply(r);
    } catch (const ChildEndedEarly&) {
        // The child closed its end: it is ending; its status says how.
        auto [status, killed] = reap(pid_, deadline);
        pid_ = -1;
        if (killed) fail(time_limit_error(t));
        try {
            throw_child_end(t, status, *page_, false);
        } catch (const Error& e) {
            fail(e);
        }
    } catch (const TimeRanOut&) {
        fail(time_limit_error(t));
    } catch (const Error& e) {
        fail(e);
    } catch (...) {
        stop();
        failed_ = Error(ErrorCode::CorruptData,
                        "reading '" + task_.file + "' was stopped by an earlier failure");
        throw;
    }
}

}  // namespace tetlod
