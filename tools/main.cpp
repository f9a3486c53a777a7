// tetlod: git-style command line. Subcommands register themselves (command.hpp);
// this file only wires them into CLI11 and maps failures to exit codes:
//   0 success, 2 bad usage (CLI11 parse errors, InvalidArgument), and otherwise
//   tetlod::exit_code_for() of the error (3 I/O, 4 bad input, 5 not built).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <exception>
#include <iostream>
#include <new>

#include "cli_common.hpp"
#include "command.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/format/container.hpp"

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
    app.set_version_flag("--version", std::string("tetlod ") + TETLOD_VERSION_STRING + " (" +
                                          tlod::format_version_string() + ")");
    app.require_subcommand(1);
    app.fallthrough();  // -q/-v also work after the subcommand name
    bool quiet = false;
    int verbose = 0;
    app.add_flag("-q,--quiet", quiet, "Print only errors");
    app.add_flag("-v,--verbose", verbose, "Print more detail (repeat for more)");
    app.footer(
        "Run 'tetlod <command> --help' for the options of a command.\n"
        "Exit codes: 0 ok, 2 bad usage, 3 I/O error, 4 bad input data, "
        "5 feature not built.");

    auto commands = cli::command_registry();
    std::stable_sort(
        commands.begin(), commands.end(),
        [](const cli::Command& a, const cli::Command& b) { return a.order < b.order; });
    std::vector<std::pair<CLI::App*, std::function<int()>>> runners;
    for (const auto& c : commands) {
        CLI::App* sub = app.add_subcommand(c.name, c.summary);
        runners.emplace_back(sub, c.setup(*sub));
    }

    // CLI11 reports a mistyped command as "A subcommand is required": name it instead.
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg.empty() || arg[0] == '-') continue;  // global options take no values
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

    try {
        for (auto& [sub, run] : runners)
            if (sub->parsed()) return run();
    } catch (const Error& e) {
        std::cerr << "tetlod: error: " << e.what() << "\n";
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
