// Table entry for OpenVDB (.vdb), present only when tetlod_vdb_io is built.
#include "tetlod/converters/features.hpp"
#include "tetlod/converters/volume_format.hpp"
#if TETLOD_HAVE_OPENVDB && TETLOD_VDB_AS_MODULE
#include "../vdb_module_loader.hpp"
#elif TETLOD_HAVE_OPENVDB
#include "tetlod/converters/vdb.hpp"
#endif

namespace tetlod {

VolumeFormat vdb_volume_format() {
    VolumeFormat f;
    f.name = "vdb";
    f.aliases = {"openvdb"};
    f.extensions = {".vdb"};
    f.description = "OpenVDB grid (--grid picks one)";
    f.not_built_hint = "OpenVDB (configure with -DTETLOD_WITH_OPENVDB=ON)";
#if TETLOD_HAVE_OPENVDB && TETLOD_VDB_AS_MODULE
    // Through the module, loaded on first use (vdb_module.hpp says why).
    f.read = [](const VolumeLocation& l, const VolumeReadOptions& o) { return vdb_module().read(l.file, o); };
    f.open_planes = [](const VolumeLocation& l, const VolumeReadOptions& o) {
        return vdb_module().open_planes(l.file, o);
    };
    f.write = [](const Volume& v, const VolumeLocation& l) { vdb_module().write(v, l.file); };
    f.write_planes = [](VolumePlanes& planes, const VolumeLocation& l) { vdb_module().write_planes(planes, l.file); };
    f.lost_metadata = [](const Volume& v) { return vdb_module().unstorable_keys(v); };
#elif TETLOD_HAVE_OPENVDB
    f.read = [](const VolumeLocation& l, const VolumeReadOptions& o) { return read_vdb(l.file, o); };
    f.open_planes = [](const VolumeLocation& l, const VolumeReadOptions& o) { return open_vdb_planes(l.file, o); };
    f.write = [](const Volume& v, const VolumeLocation& l) { write_vdb(v, l.file); };
    f.write_planes = [](VolumePlanes& planes, const VolumeLocation& l) { write_vdb(planes, l.file); };
    f.lost_metadata = vdb_unstorable_keys;
#else
    f.built = false;
#endif
    return f;
}

}  // namespace tetlod
