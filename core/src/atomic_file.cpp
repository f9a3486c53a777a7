#include "tetlod/core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {
std::string errno_text() { return std::strerror(errno); }
}  // namespace

AtomicFile::AtomicFile(std::string target_path) : target_(std::move(target_path)) {
    std::filesystem::path p(target_);
    std::filesystem::path dir = p.parent_path();
    if (dir.empty()) dir = ".";
    // mkstemp gives a unique name so concurrent writers never share a temp file.
    std::string templ = (dir / ("." + p.filename().string() + ".tmp.XXXXXX")).string();
    int fd = ::mkstemp(templ.data());
    if (fd < 0)
        throw Error(ErrorCode::IoError,
                    "cannot create a temporary file for '" + target_ + "': " + errno_text());
    temp_ = templ;
    ::fchmod(fd, 0644);
    file_ = ::fdopen(fd, "wb");
    if (!file_) {
        ::close(fd);
        ::unlink(temp_.c_str());
        throw Error(ErrorCode::IoError, "cannot open '" + temp_ + "': " + errno_text());
    }
}

AtomicFile::~AtomicFile() {
    if (file_) std::fclose(file_);
    if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::write(const void* data, std::size_t size) {
    if (size == 0) return;
    if (std::fwrite(data, 1, size, file_) != size)
        throw Error(ErrorCode::IoError, "cannot write '" + target_ + "': " + errno_text());
    written_ += size;
}

void AtomicFile::commit() {
    if (std::fflush(file_) != 0 || ::fsync(::fileno(file_)) != 0)
        throw Error(ErrorCode::IoError, "cannot flush '" + target_ + "': " + errno_text());
    if (std::fclose(file_) != 0) {
        file_ = nullptr;
        throw Error(ErrorCode::IoError, "cannot close '" + target_ + "': " + errno_text());
    }
    file_ = nullptr;
    if (::rename(temp_.c_str(), target_.c_str()) != 0)
        throw Error(ErrorCode::IoError, "cannot rename to '" + target_ + "': " + errno_text());
    committed_ = true;
}

void write_file_atomic(const std::string& path, const void* data, std::size_t size) {
    AtomicFile f(path);
    f.write(data, size);
    f.commit();
}

}  // namespace tetlod
