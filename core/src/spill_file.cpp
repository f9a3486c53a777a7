#include "tetlod/core/spill_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

SpillFile::SpillFile(const std::string& near_path) : near_(near_path) {
    std::filesystem::path dir = std::filesystem::path(near_path).parent_path();
    if (dir.empty()) dir = ".";
    std::error_code ec;
    if (near_path == "-" || !std::filesystem::is_directory(dir, ec)) dir = std::filesystem::temp_directory_path(ec);
    std::string templ = (dir / ".tetlod-spill.XXXXXX").string();
    const int fd = ::mkstemp(templ.data());
    if (fd < 0)
        throw Error(ErrorCode::IoError, "cannot create a temporary file for '" + near_path + "' in " +
                                            dir.string() + ": " + std::strerror(errno));
    ::unlink(templ.c_str());
    file_ = ::fdopen(fd, "w+b");
    if (!file_) {
        ::close(fd);
        throw Error(ErrorCode::IoError, "cannot open a temporary file for '" + near_path + "'");
    }
}

SpillFile::~SpillFile() {
    if (file_) std::fclose(file_);
}

void SpillFile::write(const void* data, std::size_t size) {
    if (size == 0) return;
    if (std::fwrite(data, 1, size, file_) != size)
        throw Error(ErrorCode::IoError, "cannot write a temporary file for '" + near_ + "': " + std::strerror(errno));
    size_ += size;
}

void SpillFile::read_back(const std::function<void(const std::byte*, std::size_t)>& piece) {
    if (std::fflush(file_) != 0 || std::fseek(file_, 0, SEEK_SET) != 0)
        throw Error(ErrorCode::IoError, "cannot read back a temporary file for '" + near_ + "'");
    std::vector<std::byte> buf(std::size_t{1} << 20);
    uint64_t left = size_;
    while (left > 0) {
        const std::size_t n = std::size_t(std::min<uint64_t>(left, buf.size()));
        if (std::fread(buf.data(), 1, n, file_) != n)
            throw Error(ErrorCode::IoError, "cannot read back a temporary file for '" + near_ + "'");
        piece(buf.data(), n);
        left -= n;
    }
    std::fseek(file_, 0, SEEK_END);
}

void SpillFile::read_range(uint64_t offset, uint64_t size,
                           const std::function<void(const std::byte*, std::size_t)>& piece) {
    if (offset > size_ || size > size_ - offset || std::fflush(file_) != 0)
        throw Error(ErrorCode::IoError, "cannot read back a temporary file for '" + near_ + "'");
    std::vector<std::byte> buf(std::size_t(std::min<uint64_t>(size, uint64_t{1} << 20)));
    const int fd = ::fileno(file_);
    while (size > 0) {
        const std::size_t n = std::size_t(std::min<uint64_t>(size, buf.size()));
        const ssize_t got = ::pread(fd, buf.data(), n, off_t(offset));
        if (got <= 0) {
            if (got < 0 && errno == EINTR) continue;
            throw Error(ErrorCode::IoError, "cannot read back a temporary file for '" + near_ + "'");
        }
        piece(buf.data(), std::size_t(got));
        offset += uint64_t(got);
        size -= uint64_t(got);
    }
}

void SpillFile::copy_to(AtomicFile& out) {
    read_back([&](const std::byte* d, std::size_t n) { out.write(d, n); });
}

}  // namespace tetlod
