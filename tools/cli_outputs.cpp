#include "cli_outputs.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <ostream>
#include <set>

#include "cli_common.hpp"

namespace tetlod::cli {

namespace {

std::set<std::string>& reported() {
    static std::set<std::string> files;
    return files;
}

// Formats with datasets (HDF5) name them FILE.h5:/dataset; anything else is a plain file.
bool split_hdf5(const std::string& name, std::string& file, std::string& dataset) {
    try {
        const VolumeLocation loc = locate_volume(name);
        if (!loc.format->datasets) return false;
        file = loc.file;
        dataset = loc.dataset;
        return true;
    } catch (const Error&) {
        return false;
    }
}

// The temporary copy of standard input, removed when the program ends.
struct StdinSpool {
    std::string dir, file;
    ~StdinSpool() {
        if (!file.empty()) ::unlink(file.c_str());
        if (!dir.empty()) ::rmdir(dir.c_str());
    }
};

}  // namespace

void add_input(OutputPolicy& policy, const std::string& input) {
    std::string file, dataset;
    if (split_hdf5(input, file, dataset))
        policy.add_input(file, dataset);  // empty dataset: the file's only one (whole file)
    else
        policy.add_input(input);
}

void precheck_output(const OutputPolicy& policy, const std::string& output) {
    if (output.empty() || is_std_stream(output)) return;
    std::string file, dataset;
    if (split_hdf5(output, file, dataset)) {
        // Adding a dataset to an existing file destroys nothing; the writer asks
        // for --force only when the dataset itself exists.
        policy.check_not_input(file, dataset.empty() ? "/volume" : dataset);
        // An existing dataset needs -f, a group is never replaced: say so before
        // the work rather than after it (main installed `policy` for the run).
        check_volume_output(output);
        return;
    }
    policy.check_output(output);
    // The files a writer creates beside the named one (a detached header's
    // data, Medit's .sol), as the format tables say.
    for (const auto& f : volume_companion_files(output)) policy.check_output(f);
    for (const auto& f : mesh_companion_files(output)) policy.check_output(f);
}

namespace {
StdinSpool& stdin_spool() {
    static StdinSpool spool;
    return spool;
}
}  // namespace

std::string with_stdin_named(std::string message) {
    const std::string& file = stdin_spool().file;
    if (file.empty()) return message;
    for (std::size_t at = message.find(file); at != std::string::npos; at = message.find(file, at + 7))
        message.replace(at, file.size(), "<stdin>");
    return message;
}

std::string stdin_as_file() {
    StdinSpool& spool = stdin_spool();
    if (!spool.file.empty()) return spool.file;
    const char* tmp = std::getenv("TMPDIR");
    std::string templ = std::string(tmp && *tmp ? tmp : "/tmp") + "/tetlod-stdin.XXXXXX";
    if (!::mkdtemp(templ.data()))
        throw Error(ErrorCode::IoError, "cannot create a temporary directory for standard input: " +
                                            std::string(std::strerror(errno)));
    spool.dir = templ;
    const std::string path = templ + "/stdin";
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0)
        throw Error(ErrorCode::IoError, "cannot create '" + path + "': " + std::strerror(errno));
    spool.file = path;
    char buf[1 << 16];
    while (true) {
        const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
        if (n == 0) break;
        if (n < 0) {
            if (errno == EINTR) continue;
            ::close(fd);
            throw Error(ErrorCode::IoError, std::string("cannot read standard input: ") + std::strerror(errno));
        }
        for (ssize_t done = 0; done < n;) {
            const ssize_t w = ::write(fd, buf + done, static_cast<std::size_t>(n - done));
            if (w < 0) {
                if (errno == EINTR) continue;
                ::close(fd);
                throw Error(ErrorCode::IoError, "cannot copy standard input to '" + path + "': " + std::strerror(errno));
            }
            done += w;
        }
    }
    ::close(fd);
    return path;
}

void mark_reported(const std::string& path) {
    reported().insert(path);
    std::string file, dataset;
    if (split_hdf5(path, file, dataset)) reported().insert(file);  // the writer records the file
}

void report_unreported(const OutputPolicy& policy) {
    for (const std::string& f : policy.written())
        if (!reported().count(f)) {
            out() << "wrote    " << f << "\n";
            reported().insert(f);
        }
}

bool container_input(const std::string& path) {
    return is_container_path(path);
}

}  // namespace tetlod::cli
