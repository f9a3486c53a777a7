#pragma once
// Bytes a streaming writer must place after data it has not written yet (a
// file header needs sizes known only at the end): kept in an anonymous
// temporary file, removed by the system when closed, so memory stays bounded.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>

namespace tetlod {

class AtomicFile;

class SpillFile {
public:
    /// A temporary file in the directory of `near_path` (where the output goes,
    /// so the spill uses the disk the output needs anyway), unlinked at once.
    /// Throws tetlod::Error(IoError) naming `near_path`.
    explicit SpillFile(const std::string& near_path);
    ~SpillFile();
    SpillFile(const SpillFile&) = delete;
    SpillFile& operator=(const SpillFile&) = delete;

    void write(const void* data, std::size_t size);
    uint64_t size() const { return size_; }
    /// Appends everything written so far to `out`.
    void copy_to(AtomicFile& out);
    /// Reads everything written so far back, in pieces of at most 1 MiB (a
    /// multiple of 8 bytes, so values never straddle two pieces).
    void read_back(const std::function<void(const std::byte* data, std::size_t size)>& piece);
    /// Reads bytes [offset, offset + size) back in pieces of at most 1 MiB.
    void read_range(uint64_t offset, uint64_t size,
                    const std::function<void(const std::byte* data, std::size_t size)>& piece);

private:
    std::string near_;
    std::FILE* file_ = nullptr;
    uint64_t size_ = 0;
};

}  // namespace tetlod
