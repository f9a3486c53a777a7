// tetlod: git-style command line. Subcommands register themselves (command.hpp);
// this file only wires them into CLI11 and maps failures to exit codes:
//   0 success, 2 bad usage (CLI11 parse errors, InvalidArgument, an output that
//   exists without -f or is an input), and otherwise exit_code_for() (exit_code.hpp) of
//   the error (3 I/O or missing file, 4 bad input data, 5 not built).
// It also installs the run's output policy (core/output_policy.hpp, -f/--force):
// inputs are registered, outputs checked before any work, "-" inputs read from
// standard input, and every file written is reported.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <exception>
#include <iostream>
#include <new>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"
#include "exit_code.hpp"

namespace tetlod::cli {

std::vector<Command>& command_registry() {
    // Function-local static: safe to use from other files' static initialisers.
    static std::vector<Command> registry;
    return registry;
}

}  // namespace tetlod::cli

int main(int argc, char** argv) {
    using namespace tetlod;
    CLI::App app{"tetlod: multiresolution tetrahedral meshes of 3D scalar volumes", "tetlod"};
    app.set_version_flag("--version", std::string("tetlod ") + library_version() + " (" +
                                          format_version() + ")");
    app.require_subcommand(1);
    app.fallthrough();  // -q/-v also work after the subcommand name
    bool quiet = false;
    int verbose = 0;
    app.add_flag("-q,--quiet", quiet, "Print only errors");
    app.add_flag("-v,--verbose", verbose, "Print more detail (repeat for more)");
    int threads = 0;
    app.add_option("-T,--threads", threads, "Use at most N threads (0: all cores); results are the same for any N")
        ->check(CLI::NonNegativeNumber);
    bool progress = false, no_progress = false;
    app.add_flag("--progress", progress, "Show progress on stderr even when it is not a terminal");
    app.add_flag("--no-progress", no_progress, "Never show progress (default: only on a terminal, not with -q)");
    bool force = false;
    app.add_flag("-f,--force", force, "Overwrite existing output files (never an input of the command)");
    app.footer(
        "Run 'tetlod <command> --help' for the options of a command.\n"
        "Outputs: an existing file (or the data file of a .nhdr/.mhd, the .sol of a .mesh) is\n"
        "only replaced with -f; an input of the same command never; FILE.h5:/path adds or\n"
        "replaces that one dataset. '-' is standard output (or input) where the format streams:\n"
        "results then go to stderr. Every file written is reported.\n"
        "Exit codes: 0 ok, 2 bad usage (also: output exists without -f, or is an input),\n"
        "3 I/O error or missing file, 4 bad input data, 5 feature not built.");

    auto commands = cli::command_registry();
    std::stable_sort(
        commands.begin(), commands.end(),
        [](const cli::Command& a, const cli::Command& b) { return a.order < b.order; });
    std::vector<std::pair<CLI::App*, std::function<int()>>> runners;
    for (const auto& c : commands) {
        CLI::App* sub = app.add_subcommand(c.name, c.summary);
        runners.emplace_back(sub, c.setup(*sub));
        // "-" as the input: standard input, copied to a temporary file when parsed.
        if (CLI::Option* in = sub->get_option_no_throw("input"))
            in->transform([](const std::string& s) { return is_std_stream(s) ? cli::stdin_as_file() : s; },
                          "", "stdin");
    }

    // CLI11 reports a mistyped command as "A subcommand is required": name it instead.
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "-T" || arg == "--threads") {  // the one global option with a value
            ++i;
            continue;
        }
        if (arg.empty() || arg[0] == '-') continue;
        bool known = false;
        std::string names;
        for (const auto& c : commands) {
            known = known || c.name == arg;
            names += (names.empty() ? "" : ", ") + c.name;
        }
        if (!known) {
            std::cerr << "tetlod: error: unknown command '" << arg << "' (commands: " << names
                      << ")\nRun 'tetlod --help' for usage.\n";
            return 2;
        }
        break;
    }

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "tetlod: error: " << e.what() << "\n"
                  << "Run 'tetlod --help' or 'tetlod <command> --help' for usage.\n";
        return 2;
    }
    cli::set_verbosity(quiet ? -1 : verbose);
    if (no_progress) cli::set_progress(false);
    else if (progress) cli::set_progress(true);

    const ThreadLimit thread_limit(threads);
    OutputPolicy policy;
    policy.force = force;
    policy.force_hint = "use -f/--force to overwrite it";
    ScopedOutputPolicy policy_scope(policy);
    try {
        for (auto& [sub, run] : runners) {
            if (!sub->parsed()) continue;
            std::string output;
            if (CLI::Option* in = sub->get_option_no_throw("input"); in && in->count())
                cli::add_input(policy, in->as<std::string>());
            if (CLI::Option* o = sub->get_option_no_throw("output"); o && o->count())
                output = o->as<std::string>();
            if (is_std_stream(output)) cli::set_results_to_stderr(true);  // stdout carries the data
            cli::precheck_output(policy, output);
            const int code = run();
            cli::mark_reported(output);  // the command's own summary line names it
            // JSON on stdout stays parseable: the file list then goes to stderr.
            if (CLI::Option* j = sub->get_option_no_throw("--json"); j && j->count())
                cli::set_results_to_stderr(true);
            cli::report_unreported(policy);
            return code;
        }
    } catch (const Error& e) {
        std::cerr << "tetlod: error: " << cli::with_stdin_named(e.what()) << "\n";
        return exit_code_for(e.code());
    } catch (const std::bad_alloc&) {
        std::cerr << "tetlod: error: out of memory\n";
        return exit_code_for(ErrorCode::TooLarge);
    } catch (const std::exception& e) {
        std::cerr << "tetlod: internal error: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
