#pragma once
// The command line's side of the output policy (core/output_policy.hpp): main
// installs one policy per run (-f/--force, the inputs given), checks the output
// names before any work, maps "-" inputs to standard input, and reports every
// file written that the command did not report itself.
#include <string>

namespace tetlod {
class OutputPolicy;
}

namespace tetlod::cli {

/// Registers an input as typed (FILE.h5:/dataset: that dataset of FILE).
void add_input(OutputPolicy& policy, const std::string& input);

/// Refuses, before any work, an output that is an input or exists without
/// --force: the name itself and the sidecar a name implies (.nhdr/.mhd data
/// file, Medit .sol). Writers check again (and every other file) when opening.
void precheck_output(const OutputPolicy& policy, const std::string& output);

/// "-" as an input: standard input, copied once to a private temporary file
/// (removed at exit) so every reader can read it. Returns the file's path.
std::string stdin_as_file();
/// `message` with the spool file of standard input (if any) named "<stdin>", so
/// that errors about a '-' input speak of what the user gave.
std::string with_stdin_named(std::string message);

/// The command printed its own line for `path`: main does not repeat it.
void mark_reported(const std::string& path);
/// One "wrote PATH" line per written file not yet reported.
void report_unreported(const OutputPolicy& policy);

/// A .tlod input: a file starting with the container magic, or any name ending
/// in .tlod (a missing or broken one then gets the container reader's message).
bool container_input(const std::string& path);

}  // namespace tetlod::cli
