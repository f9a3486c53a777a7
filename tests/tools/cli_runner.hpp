#pragma once
// Running the built `tetlod` (TETLOD_CLI_PATH) from a test as a user would, with
// stdout and stderr captured apart into per-test files in TETLOD_TEST_TMP.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace tetlod_cli_test {

inline std::string tmp(const std::string& name) {
    return (std::filesystem::path(TETLOD_TEST_TMP) / name).string();
}

inline std::string slurp(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

struct CliRun {
    int code = -1;
    std::string out, err;
};

/// Runs a shell command line; ctest runs tests in parallel processes, so the
/// capture files are named after the current test.
inline CliRun sh(const std::string& cmd) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string test = std::string(info->test_suite_name()) + "." + info->name();
    for (char& c : test)
        if (c == '/') c = '_';  // parameterized names
    const std::string out = tmp(test + ".stdout"), err = tmp(test + ".stderr");
    const int status = std::system((cmd + " >'" + out + "' 2>'" + err + "'").c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

/// Runs `tetlod -f ARGS`: the suites rerun into the same files, so outputs may
/// be replaced (-f never lets an output replace an input).
inline CliRun run(const std::string& args) {
    return sh(std::string("'") + TETLOD_CLI_PATH + "' -f " + args);
}

/// Runs `tetlod ARGS` without -f: existing outputs are refused.
inline CliRun run_no_force(const std::string& args) {
    return sh(std::string("'") + TETLOD_CLI_PATH + "' " + args);
}

}  // namespace tetlod_cli_test
