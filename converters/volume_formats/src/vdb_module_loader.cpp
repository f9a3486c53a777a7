// Where the OpenVDB module is looked for, in order:
//   1. TETLOD_VDB_MODULE, a path to the module (relocated or unusual layouts);
//   2. already in the process (a program that links tetlod_vdb_io itself);
//   3. beside the program or library holding this code, through the relative
//      directories of the install layout (bin/ -> lib/, the Python package ->
//      lib/): installed and relocated trees;
//   4. the build tree the code was compiled in, then the configured install
//      directory;
//   5. the dynamic linker's own search (LD_LIBRARY_PATH, ld.so.cache).
#include "vdb_module_loader.hpp"

#include <dlfcn.h>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

#include <filesystem>
#include <mutex>
#include <string>
#include <system_error>
#include <vector>

#include "tetlod/core/error.hpp"

namespace tetlod {
namespace {

namespace fs = std::filesystem;

constexpr const char* kEntryPoint = "tetlod_vdb_module_v1";

std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> out;
    std::size_t start = 0;
    for (std::size_t i = 0; i <= s.size(); ++i)
        if (i == s.size() || s[i] == sep) {
            if (i > start) out.push_back(s.substr(start, i - start));
            start = i + 1;
        }
    return out;
}

/// Directories of the objects this code may live in: the running program (the
/// code is usually linked statically into it) and, when different, the shared
/// object holding this function (a Python extension module).
std::vector<fs::path> own_directories() {
    std::vector<fs::path> dirs;
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) dirs.push_back(exe.parent_path());
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&vdb_module), &info) && info.dli_fname && info.dli_fname[0] == '/') {
        const fs::path dir = fs::path(info.dli_fname).parent_path();
        if (dirs.empty() || dirs.front() != dir) dirs.push_back(dir);
    }
    return dirs;
}

struct Loaded {
    const VdbModuleV1* table = nullptr;
    std::string failure;
};

Loaded load() {
    const std::string file = TETLOD_VDB_MODULE_FILE_NAME;
    std::vector<std::string> tried;
    std::string last_error;
    auto try_open = [&](const std::string& what, int flags) -> const VdbModuleV1* {
        void* handle = dlopen(what.c_str(), flags);
        if (!handle) {
            if (!(flags & RTLD_NOLOAD)) {
                tried.push_back(what);
                if (const char* e = dlerror()) last_error = e;
            }
            return nullptr;
        }
        using Entry = const VdbModuleV1* (*)();
        const auto entry = reinterpret_cast<Entry>(dlsym(handle, kEntryPoint));
        if (!entry) {
            tried.push_back(what);
            last_error = what + " has no " + kEntryPoint + " (not a tetlod OpenVDB module of this version)";
            return nullptr;
        }
        const VdbModuleV1* table = entry();
        if (std::strcmp(table->build_id, TETLOD_BUILD_ID) != 0) {
            tried.push_back(what);
            last_error = what + " is from another build (id " + table->build_id + ", this one " + TETLOD_BUILD_ID + ")";
            return nullptr;  // left loaded (unloading OpenVDB is not safe), unused
        }
        return table;  // the handle stays open for the life of the process
    };
    // Named by the user: that file or an error, never a silent other one.
    if (const char* env = std::getenv("TETLOD_VDB_MODULE"); env && *env) {
        if (auto t = try_open(env, RTLD_NOW | RTLD_LOCAL)) return {t, {}};
        return {nullptr, std::string("cannot load the OpenVDB module named by TETLOD_VDB_MODULE, '") + env +
                             "'" + (last_error.empty() ? "" : ": " + last_error)};
    }
    if (auto t = try_open(file, RTLD_NOW | RTLD_NOLOAD)) return {t, {}};
    std::vector<fs::path> dirs;
    for (const fs::path& own : own_directories())
        for (const std::string& rel : split(TETLOD_VDB_MODULE_RELATIVE_DIRS, ':')) dirs.push_back(own / rel);
    dirs.emplace_back(TETLOD_VDB_MODULE_BUILD_DIR);
    dirs.emplace_back(TETLOD_VDB_MODULE_INSTALL_DIR);
    for (const fs::path& dir : dirs) {
        const fs::path candidate = (dir / file).lexically_normal();
        std::error_code ec;
        if (!fs::is_regular_file(candidate, ec)) {
            tried.push_back(candidate.string());
            continue;
        }
        if (auto t = try_open(candidate.string(), RTLD_NOW | RTLD_LOCAL)) return {t, {}};
    }
    if (auto t = try_open(file, RTLD_NOW | RTLD_LOCAL)) return {t, {}};
    std::string where;
    for (const std::string& t : tried) where += (where.empty() ? "" : ", ") + t;
    return {nullptr, "cannot load the OpenVDB module " + file + " (looked for " + where + ")" +
                         (last_error.empty() ? "" : ": " + last_error) +
                         "; set TETLOD_VDB_MODULE to its path"};
}

}  // namespace

const VdbModuleV1& vdb_module() {
    static std::once_flag once;
    static Loaded loaded;
    std::call_once(once, [] { loaded = load(); });
    if (!loaded.table) throw Error(ErrorCode::NotBuilt, loaded.failure);
    return *loaded.table;
}

}  // namespace tetlod
