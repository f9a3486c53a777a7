#pragma once
// Runs the built `tetlod` with arguments (no shell) and reports its exit code,
// stderr, peak resident memory (including any child it started: wait4 counts
// the waited-for descendants too) and wall time. For memory bounds of refusals.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace tetlod::test {

struct CliOutcome {
    int code = -1;        // exit code, -1 when killed by a signal
    std::string err;      // stderr
    long max_rss_kib = 0; // peak RSS of the process tree
    double seconds = 0;
};

inline CliOutcome run_cli(const std::vector<std::string>& args, const std::string& stderr_path) {
    std::vector<char*> argv;
    std::string cli = TETLOD_CLI_PATH;
    argv.push_back(cli.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = ::fork();
    if (pid == 0) {
        int fd = ::open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) ::dup2(fd, 2);
        int nul = ::open("/dev/null", O_WRONLY);
        if (nul >= 0) ::dup2(nul, 1);
        ::execv(argv[0], argv.data());
        ::_exit(127);
    }
    CliOutcome out;
    int status = 0;
    rusage ru{};
    ::wait4(pid, &status, 0, &ru);
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    out.max_rss_kib = ru.ru_maxrss;
    std::ifstream f(stderr_path, std::ios::binary);
    out.err.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    return out;
}

}  // namespace tetlod::test
