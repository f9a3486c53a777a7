#pragma once
// Output policy: which files a program may write. Archives are lost when a tool
// silently replaces an existing file or one of its own inputs, so a program
// (the tetlod command line does this once in main) installs a policy:
//
//   tetlod::OutputPolicy policy;
//   policy.force = user_gave_force;            // replace existing outputs?
//   policy.add_input("scan.nhdr");             // files the run reads
//   tetlod::ScopedOutputPolicy scope(policy);  // consulted by every AtomicFile
//   ... read, compute, write ...
//   for (auto& f : policy.written()) report(f);
//
// Readers register the extra files they open (the data files of a detached
// header) through note_input_file(). Every writer of the library opens its
// outputs through AtomicFile or AtomicPath, which call check_output() before
// the first byte is written and record_written() on commit. Without an
// installed policy nothing is refused (the library's behaviour before policies).
#include <cstdint>
#include <string>
#include <vector>

namespace tetlod {

/// "-" names standard output for writers and standard input for readers.
inline bool is_std_stream(const std::string& path) { return path == "-"; }

/// Where a writer's bytes end up once symbolic links are followed.
struct OutputTarget {
    enum class Kind {
        Missing,  // nothing there yet: created by rename of a temporary file
        Regular,  // an existing regular file: replaced by rename of a temporary file
        InPlace,  // a character device or FIFO: opened and written in place
        Stdout,   // "-"
    };
    Kind kind = Kind::Missing;
    std::string path;  // after following symlinks (the file actually replaced)
};

/// Follows symbolic links from `path` (a link keeps its link: its final target
/// is what gets replaced). Throws Error(IoError) for a directory, a block device,
/// a socket, a link loop, or a missing parent directory.
OutputTarget resolve_output(const std::string& path);

class OutputPolicy {
public:
    /// Replace existing outputs (the command line's -f/--force).
    bool force = false;
    /// How the user allows replacing, appended to the refusal message.
    std::string force_hint = "set OutputPolicy::force to replace it";

    /// A file the run reads; `part` names a piece inside it (an HDF5 dataset;
    /// empty: the whole file). "-" (standard input) is ignored.
    void add_input(const std::string& path, const std::string& part = {});
    /// Throws Error(InvalidArgument) when `path` (and `part`) is one of the inputs:
    /// same file (device and inode, symlinks followed) and the same or an
    /// unspecified part.
    void check_not_input(const std::string& path, const std::string& part = {}) const;
    /// Throws Error(InvalidArgument) "'what' already exists" when `exists` and not force.
    void check_replace(const std::string& what, bool exists) const;
    /// A whole-file output: not an input, and an existing regular file only with
    /// force. Devices, FIFOs and "-" pass.
    void check_output(const std::string& path) const;

    void record_written(const std::string& path);
    /// Files committed so far, in order, as the writers named them.
    const std::vector<std::string>& written() const { return written_; }

private:
    struct Identity {
        bool exists = false;
        uint64_t dev = 0, ino = 0;
        std::string canonical;  // for files that do not exist
        std::string part;
    };
    static Identity identity_of(const std::string& path, const std::string& part);
    std::vector<Identity> inputs_;
    std::vector<std::string> written_;
};

/// Installs `policy` for the whole process until destroyed (the previous one
/// is restored). Writers on other threads see it too.
class ScopedOutputPolicy {
public:
    explicit ScopedOutputPolicy(OutputPolicy& policy);
    ~ScopedOutputPolicy();
    ScopedOutputPolicy(const ScopedOutputPolicy&) = delete;
    ScopedOutputPolicy& operator=(const ScopedOutputPolicy&) = delete;

private:
    OutputPolicy* previous_;
};

/// The installed policy, or nullptr.
OutputPolicy* active_output_policy();

/// Shorthands consulting the installed policy (no-ops without one).
void check_output(const std::string& path);
void note_input_file(const std::string& path, const std::string& part = {});
void record_written(const std::string& path);
/// True when a policy is installed without force.
bool outputs_must_not_exist();

}  // namespace tetlod
