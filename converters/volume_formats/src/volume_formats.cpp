// Volume format dispatcher: picks the table entry (volume_format.hpp) from the
// file name or the format name given, then calls its reader or writer.
#include "tetlod/converters/volume_formats.hpp"

#include <algorithm>
#include <cctype>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

const VolumeFormat& built(const VolumeLocation& loc, const std::string& path) {
    if (!loc.format->built)
        throw Error(ErrorCode::NotBuilt,
                    "'" + path + "': this tetlod was built without " +
                        (loc.format->not_built_hint.empty() ? loc.format->name : loc.format->not_built_hint));
    return *loc.format;
}

}  // namespace

VolumeLocation locate_volume(const std::string& path, const std::string& format) {
    VolumeLocation loc;
    loc.file = path;
    loc.format_name = lower(format);
    const std::string l = lower(path);
    // FILE.ext:/dataset for formats with datasets (the dataset part may itself contain ':' or '.').
    for (const auto& f : volume_formats()) {
        if (!f.datasets) continue;
        for (const auto& ext : f.extensions) {
            const auto p = l.find(ext + ":");
            if (p == std::string::npos) continue;
            const std::size_t cut = p + ext.size();
            loc.format = &f;
            loc.file = path.substr(0, cut);
            loc.dataset = path.substr(cut + 1);
            if (!format.empty() && find_volume_format(format) != &f)
                throw Error(ErrorCode::InvalidArgument, "'" + path + "' names a " + f.name +
                                                            " dataset but the format given is '" + format + "'");
            return loc;
        }
    }
    if (!format.empty()) {
        loc.format = find_volume_format(format);
        if (!loc.format) {
            std::string known;
            for (const auto& n : volume_format_names()) known += (known.empty() ? "" : ", ") + n;
            throw Error(ErrorCode::InvalidArgument,
                        "unknown volume format '" + format + "' (known: " + known + ")");
        }
        return loc;
    }
    // '-' (standard input or output) has no extension: it carries raw samples, as
    // zstd's and tar's '-' carry their own stream, unless a format is named.
    if (path == "-") {
        loc.format = find_volume_format("raw");
        if (loc.format) return loc;
    }
    for (const auto& f : volume_formats())
        for (const auto& ext : f.extensions)
            if (ends_with(l, ext)) {
                loc.format = &f;
                return loc;
            }
    throw Error(ErrorCode::InvalidArgument, "cannot tell the volume format of '" + path +
                                                "' from its name (known: " + volume_format_summary() + ")");
}

namespace {

/// Where a name to read points: by extension, else the format that claims it.
VolumeLocation locate_input(const std::string& path, const VolumeReadOptions& options) {
    VolumeLocation loc;
    try {
        loc = locate_volume(path);
    } catch (const Error&) {
        // A name no extension matches may still be claimed by a format (raw).
        const auto& all = volume_formats();
        const auto claimer = std::find_if(all.begin(), all.end(), [&](const VolumeFormat& f) {
            return f.claims_unknown_name && f.claims_unknown_name(path, options);
        });
        if (claimer == all.end()) throw;
        loc.format = &*claimer;
        loc.file = path;
    }
    return loc;
}

}  // namespace

Volume read_volume(const std::string& path, const VolumeReadOptions& options) {
    const VolumeLocation loc = locate_input(path, options);
    return built(loc, path).read(loc, options);
}

std::unique_ptr<VolumePlanes> open_volume_planes(const std::string& path, const VolumeReadOptions& options) {
    const VolumeLocation loc = locate_input(path, options);
    const VolumeFormat& f = built(loc, path);
    if (!f.open_planes) return nullptr;
    return f.open_planes(loc, options);
}

void write_volume(const Volume& volume, const std::string& path, const std::string& format) {
    const VolumeLocation loc = locate_volume(path, format);
    built(loc, path).write(volume, loc);
}

bool volume_format_writes_planes(const std::string& path, const std::string& format) {
    const VolumeLocation loc = locate_volume(path, format);
    return loc.format->built && bool(loc.format->write_planes);
}

void write_volume(VolumePlanes& planes, const std::string& path, const std::string& format) {
    const VolumeLocation loc = locate_volume(path, format);
    const VolumeFormat& f = built(loc, path);
    if (f.write_planes) {
        f.write_planes(planes, loc);
        return;
    }
    f.write(read_all_planes(planes), loc);
}

std::vector<std::string> metadata_keys_lost(const Volume& volume, const std::string& path,
                                            const std::string& format) {
    const VolumeLocation loc = locate_volume(path, format);
    if (!loc.format->lost_metadata) return {};
    return loc.format->lost_metadata(volume);
}

std::vector<std::string> volume_companion_files(const std::string& path, const std::string& format) {
    VolumeLocation loc;
    try {
        loc = locate_volume(path, format);
    } catch (const Error&) {
        return {};
    }
    if (!loc.format->companion_files) return {};
    return loc.format->companion_files(loc);
}

void check_volume_output(const std::string& path, const std::string& format) {
    const VolumeLocation loc = locate_volume(path, format);
    if (loc.format->built && loc.format->check_output) loc.format->check_output(loc);
}

}  // namespace tetlod
