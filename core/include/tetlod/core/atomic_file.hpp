#pragma once
// Atomic output: data goes to a temporary file beside the target, is flushed to
// disk, and replaces the target by rename() only on commit(). A process killed at
// any moment leaves either no file or the complete previous one at the target.
#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>

namespace tetlod {

class AtomicFile {
public:
    /// Opens a temporary file in the target's directory. Throws tetlod::Error(IoError).
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
    const std::string& temp_path() const { return temp_; }

private:
    std::string target_;
    std::string temp_;
    std::FILE* file_ = nullptr;
    std::size_t written_ = 0;
    bool committed_ = false;
};

/// Writes a whole buffer atomically.
void write_file_atomic(const std::string& path, const void* data, std::size_t size);

}  // namespace tetlod
