#pragma once
// The data file a detached header (NRRD .nhdr, MetaImage .mhd) is written with:
// NAME.raw beside NAME.ext (the writers' default, uncompressed).
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

namespace tetlod::detail {

/// `forced`: +1 the format name asks for the detached layout, -1 for the
/// attached one, 0 the extension decides (detached when it is `detached_ext`).
inline std::vector<std::string> detached_data_file(const std::string& header, int forced,
                                                   const std::string& detached_ext) {
    const std::filesystem::path p(header);
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    const bool detached = forced > 0 || (forced == 0 && ext == detached_ext);
    if (!detached) return {};
    return {(p.parent_path() / (p.stem().string() + ".raw")).string()};
}

}  // namespace tetlod::detail
