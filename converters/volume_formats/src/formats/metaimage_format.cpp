// Table entry for MetaImage: .mha (attached) and .mhd (detached); --format mha or
// mhd forces the layout whatever the extension.
#include "detached_data_file.hpp"
#include "tetlod/converters/metaimage.hpp"
#include "tetlod/converters/volume_format.hpp"

namespace tetlod {

namespace {

MetaImageWriteOptions::Layout layout(const VolumeLocation& l) {
    if (l.format_name == "mhd") return MetaImageWriteOptions::Layout::Detached;
    if (l.format_name == "mha") return MetaImageWriteOptions::Layout::Attached;
    return MetaImageWriteOptions::Layout::Auto;  // from the extension
}

}  // namespace

VolumeFormat metaimage_volume_format() {
    VolumeFormat f;
    f.name = "metaimage";
    f.aliases = {"mhd", "mha"};
    f.extensions = {".mha", ".mhd"};
    f.description = "MetaImage, attached (.mha) or detached header + .raw (.mhd)";
    f.read = [](const VolumeLocation& l, const VolumeReadOptions& o) { return read_metaimage(l.file, o); };
    f.open_planes = [](const VolumeLocation& l, const VolumeReadOptions& o) {
        return open_metaimage_planes(l.file, o);
    };
    f.write = [](const Volume& v, const VolumeLocation& l) {
        MetaImageWriteOptions o;
        o.layout = layout(l);
        write_metaimage(v, l.file, o);
    };
    f.write_planes = [](VolumePlanes& planes, const VolumeLocation& l) {
        MetaImageWriteOptions o;
        o.layout = layout(l);
        write_metaimage(planes, l.file, o);
    };
    f.lost_metadata = metaimage_unstorable_keys;
    f.companion_files = [](const VolumeLocation& l) {
        const auto lay = layout(l);
        const int forced = lay == MetaImageWriteOptions::Layout::Detached ? 1
                           : lay == MetaImageWriteOptions::Layout::Attached ? -1 : 0;
        return detail::detached_data_file(l.file, forced, ".mhd");
    };
    return f;
}

}  // namespace tetlod
