#include "tetlod/core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "tetlod/core/error.hpp"
#include "tetlod/core/output_policy.hpp"

namespace tetlod {

namespace {

std::string errno_text() { return std::strerror(errno); }

// A unique hidden temporary file beside `resolved`, with the permissions of the
// file it replaces (0644 for a new file). Returns its descriptor.
int make_temp_beside(const std::string& resolved, const std::string& target, std::string& temp) {
    std::filesystem::path p(resolved);
    std::filesystem::path dir = p.parent_path();
    if (dir.empty()) dir = ".";
    // mkstemp gives a unique name so concurrent writers never share a temp file.
    std::string name = p.filename().string();
    name.insert(name.begin(), '.');  // (not "." + s: GCC 12 -Wrestrict false positive)
    name += ".tmp.XXXXXX";
    std::string templ = (dir / name).string();
    int fd = ::mkstemp(templ.data());
    if (fd < 0)
        throw Error(ErrorCode::IoError,
                    "cannot create a temporary file for '" + target + "': " + errno_text());
    temp = templ;
    struct stat st {};
    const mode_t mode = ::stat(resolved.c_str(), &st) == 0 ? (st.st_mode & 07777) : 0644;
    ::fchmod(fd, mode);
    return fd;
}

// rename(), but without replacing a file that appeared since the policy allowed
// creating the target (another process, or two outputs of one run with one name).
void rename_into_place(const std::string& temp, const std::string& resolved, const std::string& target,
                       bool no_replace) {
    if (no_replace) {
        if (::renameat2(AT_FDCWD, temp.c_str(), AT_FDCWD, resolved.c_str(), RENAME_NOREPLACE) == 0) return;
        if (errno == EEXIST) {
            const auto* p = active_output_policy();
            throw Error(ErrorCode::InvalidArgument,
                        "'" + target + "' appeared while it was being written; " +
                            (p ? p->force_hint : std::string("remove it")));
        }
        if (errno != EINVAL && errno != ENOSYS)  // else: a file system without the flag
            throw Error(ErrorCode::IoError, "cannot rename to '" + target + "': " + errno_text());
    }
    if (::rename(temp.c_str(), resolved.c_str()) != 0)
        throw Error(ErrorCode::IoError, "cannot rename to '" + target + "': " + errno_text());
}

}  // namespace

AtomicFile::AtomicFile(std::string target_path) : target_(std::move(target_path)) {
    const OutputTarget t = resolve_output(target_);
    resolved_ = t.path;
    if (t.kind == OutputTarget::Kind::Stdout || t.kind == OutputTarget::Kind::InPlace) {
        in_place_ = true;
        const int fd = t.kind == OutputTarget::Kind::Stdout
                           ? ::dup(STDOUT_FILENO)
                           : ::open(resolved_.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
        if (fd < 0) throw Error(ErrorCode::IoError, "cannot open '" + target_ + "': " + errno_text());
        file_ = ::fdopen(fd, "wb");
        if (!file_) {
            ::close(fd);
            throw Error(ErrorCode::IoError, "cannot open '" + target_ + "': " + errno_text());
        }
        return;
    }
    check_output(target_);
    no_replace_ = t.kind == OutputTarget::Kind::Missing && outputs_must_not_exist();
    const int fd = make_temp_beside(resolved_, target_, temp_);
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
    if (std::fflush(file_) != 0)
        throw Error(ErrorCode::IoError, "cannot flush '" + target_ + "': " + errno_text());
    // fsync makes the rename durable; pipes and terminals have nothing to sync.
    if (!in_place_ && ::fsync(::fileno(file_)) != 0)
        throw Error(ErrorCode::IoError, "cannot flush '" + target_ + "': " + errno_text());
    const int closed = std::fclose(file_);
    file_ = nullptr;
    if (closed != 0) throw Error(ErrorCode::IoError, "cannot close '" + target_ + "': " + errno_text());
    if (!in_place_) rename_into_place(temp_, resolved_, target_, no_replace_);
    committed_ = true;
    record_written(target_);
}

void write_file_atomic(const std::string& path, const void* data, std::size_t size) {
    AtomicFile f(path);
    f.write(data, size);
    f.commit();
}

AtomicPath::AtomicPath(std::string target_path, const std::string& format, bool check_policy)
    : target_(std::move(target_path)) {
    const OutputTarget t = resolve_output(target_);
    if (t.kind == OutputTarget::Kind::Stdout)
        throw Error(ErrorCode::InvalidArgument,
                    format + " cannot be written to standard output ('-'): it needs a seekable "
                             "file; give a file name");
    if (t.kind == OutputTarget::Kind::InPlace)
        throw Error(ErrorCode::InvalidArgument,
                    "'" + target_ + "': " + format +
                        " cannot be written to a device or FIFO (it needs a seekable regular file)");
    resolved_ = t.path;
    exists_ = t.kind == OutputTarget::Kind::Regular;
    if (check_policy) check_output(target_);
    const int fd = make_temp_beside(resolved_, target_, temp_);
    ::close(fd);
}

AtomicPath::~AtomicPath() {
    if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicPath::commit() {
    const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
    }
    rename_into_place(temp_, resolved_, target_, !exists_ && outputs_must_not_exist());
    committed_ = true;
    record_written(target_);
}

}  // namespace tetlod
