#include "tetlod/core/regular_file.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

const char* kind_of(mode_t mode) {
    if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a regular file";
}

}  // namespace

void require_regular_file(const std::string& path, const std::string& what) {
    if (path == "-") return;
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
        const int err = errno;
        if (err == ENOENT || err == ENOTDIR)
            throw Error(ErrorCode::IoError, "cannot open '" + path + "': no such file (" + what + ")");
        throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + std::strerror(err) + " (" + what + ")");
    }
    if (!S_ISREG(st.st_mode))
        throw Error(ErrorCode::IoError, "cannot read " + what + " '" + path + "': it is " + kind_of(st.st_mode) +
                                            ", not a regular file");
}

std::optional<Failure> regular_file_failure(const std::string& path, const std::string& what) {
    auto checked = capture([&] { require_regular_file(path, what); });
    if (!checked) return checked.failure();
    return std::nullopt;
}

}  // namespace tetlod
