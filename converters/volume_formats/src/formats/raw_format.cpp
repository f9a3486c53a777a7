// Table entry for raw samples (.raw; any name when dims and type are known).
#include "tetlod/converters/raw_volume.hpp"
#include "tetlod/converters/volume_format.hpp"

namespace tetlod {

VolumeFormat raw_volume_format() {
    VolumeFormat f;
    f.name = "raw";
    f.extensions = {".raw"};
    f.description = "raw samples (dims/type from flags or a NAME_XxYxZ_DTYPE.raw name)";
    f.read = [](const VolumeLocation& l, const VolumeReadOptions& o) { return read_raw_volume(l.file, o); };
    f.open_planes = [](const VolumeLocation& l, const VolumeReadOptions& o) {
        return open_raw_volume_planes(l.file, o);
    };
    f.write = [](const Volume& v, const VolumeLocation& l) { write_raw_volume(v, l.file, Endian::Little); };
    f.write_planes = [](VolumePlanes& planes, const VolumeLocation& l) {
        write_raw_volume(planes, l.file, Endian::Little);
    };
    f.lost_metadata = [](const Volume& v) {
        std::vector<std::string> all;
        for (const auto& [k, value] : v.metadata) all.push_back(k);
        return all;
    };
    // Raw data come with all sorts of extensions (.bin, .dat, .img, none).
    f.claims_unknown_name = [](const std::string& path, const VolumeReadOptions& o) {
        return (o.dims && o.type) || parse_raw_volume_name(path).has_value();
    };
    return f;
}

}  // namespace tetlod
