#pragma once
// Atomic output: data goes to a temporary file beside the target, is flushed to
// disk, and replaces the target by rename() only on commit(). A process killed at
// any moment leaves either no file or the complete previous one at the target.
//
// Special targets (see output_policy.hpp):
//  - "-" is standard output, written in place;
//  - a character device or FIFO is opened and written in place (renaming a
//    regular file over /dev/stdout or a FIFO would destroy it);
//  - a symbolic link keeps its link: its final target is replaced atomically
//    (the temporary file goes beside the target, not beside the link).
// The installed OutputPolicy is consulted before the first byte is written
// (an input of the run, or an existing file without force, is refused) and told
// of every committed file.
#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>

namespace tetlod {

class AtomicFile {
public:
    /// Opens a temporary file beside the (resolved) target, or the target itself
    /// for "-", devices and FIFOs. Throws tetlod::Error(IoError), or
    /// Error(InvalidArgument) when the output policy refuses the target.
    explicit AtomicFile(std::string target_path);
    ~AtomicFile();  // removes the temporary file unless committed
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    void write(const void* data, std::size_t size);
    void write(std::string_view s) { write(s.data(), s.size()); }
    /// Bytes written so far.
    std::size_t size() const { return written_; }
    /// Flushes, fsyncs and renames over the target. Throws tetlod::Error(IoError).
    void commit();

    const std::string& target() const { return target_; }
    /// The temporary file (empty when writing in place).
    const std::string& temp_path() const { return temp_; }
    /// True for "-", devices and FIFOs (no temporary file, no rename).
    bool in_place() const { return in_place_; }

private:
    std::string target_;    // as given (reported)
    std::string resolved_;  // symlinks followed (renamed over)
    std::string temp_;
    std::FILE* file_ = nullptr;
    std::size_t written_ = 0;
    bool committed_ = false;
    bool in_place_ = false;
    bool no_replace_ = false;  // the target did not exist and may not appear meanwhile
};

/// Writes a whole buffer atomically.
void write_file_atomic(const std::string& path, const void* data, std::size_t size);

/// For writers whose third-party library writes the file by name itself (HDF5,
/// OpenVDB): an empty temporary file beside the resolved target, renamed over it
/// by commit(). These libraries need a seekable regular file, so "-", devices
/// and FIFOs are refused (Error(InvalidArgument) naming `format`).
class AtomicPath {
public:
    /// `check_policy` false: the caller consults the output policy itself (HDF5
    /// replaces one dataset of an existing file, not the file).
    AtomicPath(std::string target_path, const std::string& format, bool check_policy = true);
    ~AtomicPath();  // removes the temporary file unless committed
    AtomicPath(const AtomicPath&) = delete;
    AtomicPath& operator=(const AtomicPath&) = delete;

    const std::string& target() const { return target_; }
    /// The file that will be replaced (symlinks followed).
    const std::string& resolved_target() const { return resolved_; }
    bool target_exists() const { return exists_; }
    const std::string& temp_path() const { return temp_; }
    /// Fsyncs the temporary file and renames it over the target.
    void commit();

private:
    std::string target_, resolved_, temp_;
    bool exists_ = false;
    bool committed_ = false;
};

}  // namespace tetlod
