#pragma once
// Subcommand registry: each tools/cmd_*.cpp registers itself with a static
// CommandRegistration, so adding a subcommand never touches main.cpp.
#include <functional>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace tetlod::cli {

struct Command {
    std::string name;
    std::string summary;
    int order = 100;  // position in --help (lower first)
    /// Adds options to `sub`; returns the function to run after parsing. The
    /// function returns the process exit code; it may throw tetlod::Error.
    std::function<std::function<int()>(CLI::App& sub)> setup;
};

std::vector<Command>& command_registry();

struct CommandRegistration {
    explicit CommandRegistration(Command c) { command_registry().push_back(std::move(c)); }
};

}  // namespace tetlod::cli
