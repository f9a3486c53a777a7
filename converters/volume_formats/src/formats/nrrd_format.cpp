// Table entry for NRRD: .nrrd (attached) and .nhdr (detached); --format nrrd or
// nhdr forces the layout whatever the extension.
#include "detached_data_file.hpp"
#include "tetlod/converters/nrrd.hpp"
#include "tetlod/converters/volume_format.hpp"

namespace tetlod {

namespace {

NrrdWriteOptions::Layout layout(const VolumeLocation& l) {
    if (l.format_name == "nhdr") return NrrdWriteOptions::Layout::Detached;
    if (l.format_name == "nrrd") return NrrdWriteOptions::Layout::Attached;
    return NrrdWriteOptions::Layout::Auto;  // from the extension
}

}  // namespace

VolumeFormat nrrd_volume_format() {
    VolumeFormat f;
    f.name = "nrrd";
    f.aliases = {"nhdr"};
    f.extensions = {".nrrd", ".nhdr"};
    f.description = "NRRD, attached (.nrrd) or detached header + .raw (.nhdr)";
    f.read = [](const VolumeLocation& l, const VolumeReadOptions& o) { return read_nrrd(l.file, o); };
    f.open_planes = [](const VolumeLocation& l, const VolumeReadOptions& o) { return open_nrrd_planes(l.file, o); };
    f.write = [](const Volume& v, const VolumeLocation& l) {
        NrrdWriteOptions o;
        o.layout = layout(l);
        write_nrrd(v, l.file, o);
    };
    f.write_planes = [](VolumePlanes& planes, const VolumeLocation& l) {
        NrrdWriteOptions o;
        o.layout = layout(l);
        write_nrrd(planes, l.file, o);
    };
    f.lost_metadata = nrrd_unstorable_keys;
    f.companion_files = [](const VolumeLocation& l) {
        const auto lay = layout(l);
        const int forced = lay == NrrdWriteOptions::Layout::Detached ? 1
                           : lay == NrrdWriteOptions::Layout::Attached ? -1 : 0;
        return detail::detached_data_file(l.file, forced, ".nhdr");
    };
    return f;
}

}  // namespace tetlod
