// The one list of built-in volume formats, and the table built from it. A new
// format adds its entry function (src/formats/<name>_format.cpp) and one line
// below, in the order file names are matched and help texts list formats.
#include <algorithm>
#include <cctype>
#include <deque>

#include "tetlod/converters/volume_format.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

VolumeFormat raw_volume_format();
VolumeFormat nrrd_volume_format();
VolumeFormat metaimage_volume_format();
VolumeFormat vdb_volume_format();
VolumeFormat hdf5_volume_format();

namespace {

std::vector<VolumeFormat> built_in_formats() {
    return {
        raw_volume_format(),
        nrrd_volume_format(),
        metaimage_volume_format(),
        vdb_volume_format(),
        hdf5_volume_format(),
    };
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

// A deque: registering a format never moves the others, so the entries
// VolumeLocation points to stay valid.
std::deque<VolumeFormat>& table() {
    static std::deque<VolumeFormat> t = [] {
        auto v = built_in_formats();
        return std::deque<VolumeFormat>(v.begin(), v.end());
    }();
    return t;
}

}  // namespace

const std::deque<VolumeFormat>& volume_formats() { return table(); }

const VolumeFormat* find_volume_format(const std::string& name) {
    const std::string n = lower(name);
    for (const auto& f : table()) {
        if (f.name == n) return &f;
        for (const auto& a : f.aliases)
            if (a == n) return &f;
    }
    return nullptr;
}

void register_volume_format(VolumeFormat format) {
    auto taken = [](const std::string& what) {
        throw Error(ErrorCode::InvalidArgument, "register_volume_format: '" + what + "' is already taken");
    };
    if (format.name.empty()) throw Error(ErrorCode::InvalidArgument, "register_volume_format: no name");
    format.name = lower(format.name);
    for (auto& a : format.aliases) a = lower(a);
    for (auto& e : format.extensions) e = lower(e);
    if (find_volume_format(format.name)) taken(format.name);
    for (const auto& a : format.aliases)
        if (find_volume_format(a)) taken(a);
    for (const auto& f : table())
        for (const auto& e : f.extensions)
            if (std::find(format.extensions.begin(), format.extensions.end(), e) != format.extensions.end())
                taken(e);
    if (format.built && (!format.read || !format.write))
        throw Error(ErrorCode::InvalidArgument,
                    "register_volume_format: '" + format.name + "' is built but has no reader or writer");
    table().push_back(std::move(format));
}

bool volume_format_built(const std::string& name) {
    const VolumeFormat* f = find_volume_format(name);
    return f && f->built;
}

std::vector<std::string> volume_format_names() {
    std::vector<std::string> names;
    for (const auto& f : table()) {
        names.push_back(f.name);
        names.insert(names.end(), f.aliases.begin(), f.aliases.end());
    }
    return names;
}

std::string volume_format_summary() {
    std::string s;
    for (const auto& f : table()) {
        std::string item;
        if (f.datasets && !f.extensions.empty()) {
            item = "FILE" + f.extensions.front() + ":/dataset";
        } else {
            for (const auto& e : f.extensions) item += (item.empty() ? "" : "/") + e;
        }
        if (!f.built) item += " (not built)";
        s += (s.empty() ? "" : ", ") + item;
    }
    return s;
}

}  // namespace tetlod
