// Volume format dispatcher: picks the reader or writer from the file name.
#include "tetlod/converters/volume_formats.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <optional>

#include "tetlod/converters/metaimage.hpp"
#include "tetlod/converters/nrrd.hpp"
#include "tetlod/converters/raw_volume.hpp"
#include "tetlod/core/error.hpp"
#if TETLOD_HAVE_OPENVDB
#include "tetlod/converters/vdb.hpp"
#endif
#if TETLOD_HAVE_HDF5
#include "tetlod/converters/hdf5.hpp"
#endif

namespace tetlod {

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::optional<VolumeFormat> format_from_name(const std::string& f) {
    const std::string s = lower(f);
    if (s == "raw") return VolumeFormat::Raw;
    if (s == "nrrd" || s == "nhdr") return VolumeFormat::Nrrd;
    if (s == "mhd" || s == "mha" || s == "metaimage") return VolumeFormat::MetaImage;
    if (s == "vdb" || s == "openvdb") return VolumeFormat::Vdb;
    if (s == "h5" || s == "hdf5") return VolumeFormat::Hdf5;
    return std::nullopt;
}

[[noreturn, maybe_unused]] void not_built(VolumeFormat f, const std::string& path) {
    const char* what = f == VolumeFormat::Vdb ? "OpenVDB (configure with -DTETLOD_WITH_OPENVDB=ON)"
                                              : "HDF5 (configure with -DTETLOD_WITH_HDF5=ON)";
    throw Error(ErrorCode::NotBuilt, "'" + path + "': this tetlod was built without " + std::string(what));
}

}  // namespace

VolumeLocation locate_volume(const std::string& path, const std::string& format) {
    VolumeLocation loc;
    loc.file = path;
    const std::string l = lower(path);
    // FILE.h5:/dataset (the dataset part may itself contain ':' or '.').
    for (const char* ext : {".h5:", ".hdf5:", ".he5:"}) {
        auto p = l.find(ext);
        if (p != std::string::npos) {
            std::size_t cut = p + std::strlen(ext);
            loc.format = VolumeFormat::Hdf5;
            loc.file = path.substr(0, cut - 1);
            loc.dataset = path.substr(cut);
            if (!format.empty() && format_from_name(format) != VolumeFormat::Hdf5)
                throw Error(ErrorCode::InvalidArgument,
                            "'" + path + "' names an HDF5 dataset but the format given is '" + format + "'");
            return loc;
        }
    }
    if (!format.empty()) {
        auto f = format_from_name(format);
        if (!f)
            throw Error(ErrorCode::InvalidArgument,
                        "unknown volume format '" + format + "' (known: raw, nrrd, nhdr, mhd, mha, vdb, h5)");
        loc.format = *f;
        return loc;
    }
    if (ends_with(l, ".raw")) loc.format = VolumeFormat::Raw;
    else if (ends_with(l, ".nrrd") || ends_with(l, ".nhdr")) loc.format = VolumeFormat::Nrrd;
    else if (ends_with(l, ".mhd") || ends_with(l, ".mha")) loc.format = VolumeFormat::MetaImage;
    else if (ends_with(l, ".vdb")) loc.format = VolumeFormat::Vdb;
    else if (ends_with(l, ".h5") || ends_with(l, ".hdf5") || ends_with(l, ".he5")) loc.format = VolumeFormat::Hdf5;
    else
        throw Error(ErrorCode::InvalidArgument,
                    "cannot tell the volume format of '" + path +
                        "' from its name (known: .raw, .nrrd, .nhdr, .mhd, .mha, .vdb, FILE.h5:/dataset)");
    return loc;
}

bool volume_format_built(VolumeFormat format) {
    switch (format) {
        case VolumeFormat::Vdb: return TETLOD_HAVE_OPENVDB != 0;
        case VolumeFormat::Hdf5: return TETLOD_HAVE_HDF5 != 0;
        default: return true;
    }
}

Volume read_volume(const std::string& path, const VolumeReadOptions& options) {
    VolumeLocation loc;
    try {
        loc = locate_volume(path);
    } catch (const Error&) {
        // Any other name is a raw volume when its dims and type are known
        // (flags, or a NAME_XxYxZ_DTYPE name): raw data come with all sorts of
        // extensions (.bin, .dat, .img, none).
        if (!(options.dims && options.type) && !parse_raw_volume_name(path)) throw;
        loc.format = VolumeFormat::Raw;
        loc.file = path;
    }
    switch (loc.format) {
        case VolumeFormat::Raw: return read_raw_volume(loc.file, options);
        case VolumeFormat::Nrrd: return read_nrrd(loc.file, options);
        case VolumeFormat::MetaImage: return read_metaimage(loc.file, options);
        case VolumeFormat::Vdb:
#if TETLOD_HAVE_OPENVDB
            return read_vdb(loc.file, options);
#else
            not_built(loc.format, path);
#endif
        case VolumeFormat::Hdf5:
#if TETLOD_HAVE_HDF5
            return read_hdf5(loc.file, loc.dataset, options);
#else
            not_built(loc.format, path);
#endif
    }
    throw Error(ErrorCode::InvalidArgument, "'" + path + "': unknown volume format");
}

void write_volume(const Volume& volume, const std::string& path, const std::string& format) {
    VolumeLocation loc = locate_volume(path, format);
    switch (loc.format) {
        case VolumeFormat::Raw: write_raw_volume(volume, loc.file, Endian::Little); return;
        case VolumeFormat::Nrrd: {
            NrrdWriteOptions o;
            if (lower(format) == "nhdr") o.layout = NrrdWriteOptions::Layout::Detached;
            else if (lower(format) == "nrrd") o.layout = NrrdWriteOptions::Layout::Attached;
            write_nrrd(volume, loc.file, o);
            return;
        }
        case VolumeFormat::MetaImage: {
            MetaImageWriteOptions o;
            if (lower(format) == "mhd") o.layout = MetaImageWriteOptions::Layout::Detached;
            else if (lower(format) == "mha") o.layout = MetaImageWriteOptions::Layout::Attached;
            write_metaimage(volume, loc.file, o);
            return;
        }
        case VolumeFormat::Vdb:
#if TETLOD_HAVE_OPENVDB
            write_vdb(volume, loc.file);
            return;
#else
            not_built(loc.format, path);
#endif
        case VolumeFormat::Hdf5:
#if TETLOD_HAVE_HDF5
            write_hdf5(volume, loc.file, loc.dataset.empty() ? "/volume" : loc.dataset);
            return;
#else
            not_built(loc.format, path);
#endif
    }
}

std::vector<std::string> metadata_keys_lost(const Volume& volume, const std::string& path,
                                            const std::string& format) {
    switch (locate_volume(path, format).format) {
        case VolumeFormat::Raw: {
            std::vector<std::string> all;
            for (const auto& [k, v] : volume.metadata) all.push_back(k);
            return all;
        }
        case VolumeFormat::Nrrd: return nrrd_unstorable_keys(volume);
        case VolumeFormat::MetaImage: return metaimage_unstorable_keys(volume);
        case VolumeFormat::Vdb:
#if TETLOD_HAVE_OPENVDB
            return vdb_unstorable_keys(volume);
#else
            return {};
#endif
        case VolumeFormat::Hdf5:
#if TETLOD_HAVE_HDF5
            return hdf5_unstorable_keys(volume);
#else
            return {};
#endif
    }
    return {};
}

}  // namespace tetlod
