#pragma once
// Isolation of third-party readers. libhdf5 and OpenVDB parse untrusted files
// with their own code, which crashes (SIGSEGV, heap overflow) or loops forever
// on some corrupt inputs. tetlod cannot fix those libraries, so it runs such a
// read in a forked child process: the child does the whole read and sends the
// result back through a pipe; the parent reads it under a time limit. A child
// that dies by a signal, exits abnormally or runs out of time (it is killed)
// becomes a clean tetlod::Error(CorruptData) naming the file and what happened,
// and tetlod carries on.
//
// Library use: isolation is on by default; IsolationOptions::enabled = false runs
// the read in the calling process (for environments without fork, or to debug).
// The child uses only the thread that forked it plus whatever threads it starts
// itself: fork copies only the calling thread, so a thread pool of the parent
// (TBB) does not exist in the child. Readers that use a pool start a fresh one.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace tetlod {

struct IsolationOptions {
    /// false: run the read in this process (no protection against crashes or hangs).
    bool enabled = true;
    /// > 0: fixed time limit in seconds; otherwise base + per-MiB of the input.
    double timeout_seconds = 0;
    double base_seconds = 10;
    double seconds_per_mib = 2;
    /// Memory the child may allocate (heap and private mappings, RLIMIT_DATA;
    /// not applied in AddressSanitizer builds, whose shadow memory counts):
    /// > 0: fixed; 0: base + per input byte, so a tiny file cannot make the
    /// library allocate gigabytes (a 10 KB corrupt .vdb made OpenVDB take 7 GB).
    /// The default per-byte factor allows the 4096x expansion the readers'
    /// own checks accept (sparse and compressed data), three times over.
    uint64_t memory_limit_bytes = 0;
    uint64_t memory_base_bytes = uint64_t{96} << 20;
    double memory_per_input_byte = 3 * 4096.0;
};

/// The time limit for an input of `input_bytes` bytes.
double isolation_time_limit(const IsolationOptions& options, uint64_t input_bytes);
/// The child's memory limit for an input of `input_bytes` bytes (0: none).
uint64_t isolation_memory_limit(const IsolationOptions& options, uint64_t input_bytes);

/// The child's end of the result pipe.
class IsolatedWriter {
public:
    explicit IsolatedWriter(int fd) : fd_(fd) {}
    /// Writes everything or throws tetlod::Error(IoError) (the parent went away).
    void write(const void* data, std::size_t size);

private:
    int fd_;
};

/// The parent's end: every read waits at most until the deadline.
class IsolatedReader {
public:
    IsolatedReader(int fd, double deadline) : fd_(fd), deadline_(deadline) {}
    /// Reads exactly `size` bytes. When the child ends first or the time runs out,
    /// throws an internal exception that run_isolated turns into the right Error.
    void read(void* data, std::size_t size);
    /// True once the child closed its end (after everything it wrote was read).
    bool at_end();

private:
    int fd_;
    double deadline_;
};

struct IsolatedTask {
    /// Who reads, for messages: "the HDF5 library", "OpenVDB".
    std::string library;
    /// The file being read, for messages.
    std::string file;
    double time_limit_seconds = 10;
    /// RLIMIT_DATA of the child (0: none); running past it is an allocation
    /// failure in the child, reported as TooLarge.
    uint64_t memory_limit_bytes = 0;
};

/// Runs `child` in a forked process and `parent` here, connected by a pipe.
/// A tetlod::Error thrown in the child is rethrown here with its code and
/// message; any other exception becomes CorruptData (TooLarge for bad_alloc).
/// A child that crashes, exits without a result or exceeds the time limit (it
/// is killed with SIGKILL) becomes CorruptData. An exception thrown by `parent`
/// (e.g. while validating what the child sent) kills the child and propagates.
void run_isolated(const IsolatedTask& task, const std::function<void(IsolatedWriter&)>& child,
                  const std::function<void(IsolatedReader&)>& parent);

}  // namespace tetlod
