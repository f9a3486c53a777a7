#pragma once
// Helpers shared by the fuzz targets: splitting one input into parts on a
// separator (several sections or files from one byte string), and a private
// scratch folder for targets whose readers take paths.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace tetlod_fuzz {

/// Parts of `data` between occurrences of `sep` (at least one part).
inline std::vector<std::string_view> split(std::string_view data, std::string_view sep, std::size_t max_parts) {
    std::vector<std::string_view> out;
    std::size_t b = 0;
    while (out.size() + 1 < max_parts) {
        const std::size_t e = data.find(sep, b);
        if (e == std::string_view::npos) break;
        out.push_back(data.substr(b, e - b));
        b = e + sep.size();
    }
    out.push_back(data.substr(b));
    return out;
}

/// A folder of this process, emptied on each call: the files of one input.
inline std::string scratch_dir() {
    static const std::string dir = [] {
        std::string t = (std::filesystem::temp_directory_path() / "tetlod-fuzz-XXXXXX").string();
        if (!::mkdtemp(t.data())) std::abort();
        return t;
    }();
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec)) std::filesystem::remove_all(e.path(), ec);
    return dir;
}

inline void write_file(const std::string& path, std::string_view bytes) {
    std::ofstream f(path, std::ios::binary);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace tetlod_fuzz
