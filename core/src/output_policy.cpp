#include "tetlod/core/output_policy.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

std::atomic<OutputPolicy*> g_policy{nullptr};

// HDF5 names "/a/b" and "a/b" are the same dataset.
std::string normalized_part(const std::string& part) {
    if (part.empty()) return part;
    return part[0] == '/' ? part : "/" + part;
}

}  // namespace

OutputTarget resolve_output(const std::string& path) {
    namespace fs = std::filesystem;
    using Kind = OutputTarget::Kind;
    if (is_std_stream(path)) return {Kind::Stdout, path};
    std::string p = path;
    // Linux stops at 40 links (ELOOP); so do we, with a message naming the output.
    for (int hops = 0; hops <= 40; ++hops) {
        struct stat st {};
        if (::lstat(p.c_str(), &st) != 0) {
            if (errno == ENOENT) return {Kind::Missing, p};
            throw Error(ErrorCode::IoError, "cannot write '" + path + "': " + std::strerror(errno));
        }
        if (S_ISLNK(st.st_mode)) {
            std::error_code ec;
            const fs::path link = fs::read_symlink(p, ec);
            if (ec) throw Error(ErrorCode::IoError, "cannot read the link '" + p + "': " + ec.message());
            p = link.is_absolute() ? link.string() : (fs::path(p).parent_path() / link).string();
            continue;
        }
        if (S_ISREG(st.st_mode)) return {Kind::Regular, p};
        if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode)) return {Kind::InPlace, p};
        if (S_ISDIR(st.st_mode))
            throw Error(ErrorCode::IoError, "cannot write '" + path + "': it is a directory");
        throw Error(ErrorCode::IoError,
                    "cannot write '" + path + "': not a regular file, character device or FIFO");
    }
    throw Error(ErrorCode::IoError, "cannot write '" + path + "': too many levels of symbolic links");
}

OutputPolicy::Identity OutputPolicy::identity_of(const std::string& path, const std::string& part) {
    Identity id;
    id.part = normalized_part(part);
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) {  // follows symlinks
        id.exists = true;
        id.dev = static_cast<uint64_t>(st.st_dev);
        id.ino = static_cast<uint64_t>(st.st_ino);
        return id;
    }
    std::error_code ec;
    const auto abs = std::filesystem::absolute(path, ec);
    const auto canon = std::filesystem::weakly_canonical(ec ? std::filesystem::path(path) : abs, ec);
    id.canonical = ec ? path : canon.string();
    return id;
}

void OutputPolicy::add_input(const std::string& path, const std::string& part) {
    if (path.empty() || is_std_stream(path)) return;
    inputs_.push_back(identity_of(path, part));
}

void OutputPolicy::check_not_input(const std::string& path, const std::string& part) const {
    if (is_std_stream(path)) return;
    const Identity out = identity_of(path, part);
    for (const Identity& in : inputs_) {
        const bool same_file = out.exists && in.exists ? out.dev == in.dev && out.ino == in.ino
                                                       : !out.exists && !in.exists && out.canonical == in.canonical;
        if (!same_file) continue;
        if (!in.part.empty() && !out.part.empty() && in.part != out.part) continue;  // other dataset
        throw Error(ErrorCode::InvalidArgument,
                    "'" + path + (out.part.empty() ? "" : ":" + out.part) +
                        "' is an input of this command: refusing to overwrite it (choose another "
                        "output name)");
    }
}

void OutputPolicy::check_replace(const std::string& what, bool exists) const {
    if (exists && !force)
        throw Error(ErrorCode::InvalidArgument, "'" + what + "' already exists; " + force_hint);
}

void OutputPolicy::check_output(const std::string& path) const {
    const OutputTarget t = resolve_output(path);
    if (t.kind == OutputTarget::Kind::Stdout || t.kind == OutputTarget::Kind::InPlace) return;
    check_not_input(path);
    check_replace(path, t.kind == OutputTarget::Kind::Regular);
}

void OutputPolicy::record_written(const std::string& path) { written_.push_back(path); }

ScopedOutputPolicy::ScopedOutputPolicy(OutputPolicy& policy) : previous_(g_policy.exchange(&policy)) {}
ScopedOutputPolicy::~ScopedOutputPolicy() { g_policy.store(previous_); }

OutputPolicy* active_output_policy() { return g_policy.load(); }

void check_output(const std::string& path) {
    if (auto* p = active_output_policy()) p->check_output(path);
}

void note_input_file(const std::string& path, const std::string& part) {
    if (auto* p = active_output_policy()) p->add_input(path, part);
}

void record_written(const std::string& path) {
    if (auto* p = active_output_policy()) p->record_written(path);
}

bool outputs_must_not_exist() {
    const auto* p = active_output_policy();
    return p && !p->force;
}

}  // namespace tetlod
