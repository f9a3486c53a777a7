// The table tetlod_volume_formats finds by dlopen (vdb_module.hpp).
#include "tetlod/converters/vdb_module.hpp"

#include "tetlod/converters/vdb.hpp"

extern "C" __attribute__((visibility("default"))) const tetlod::VdbModuleV1* tetlod_vdb_module_v1() {
    using namespace tetlod;
    static const VdbModuleV1 table{
        TETLOD_BUILD_ID,
        [](const std::string& path, const VolumeReadOptions& o) { return read_vdb(path, o); },
        [](const std::string& path, const VolumeReadOptions& o) { return open_vdb_planes(path, o); },
        [](const std::string& path) { return list_vdb_grids(path); },
        [](const Volume& v, const std::string& path) { write_vdb(v, path); },
        [](VolumePlanes& planes, const std::string& path) { write_vdb(planes, path); },
        [](const Volume& v) { return vdb_unstorable_keys(v); },
    };
    return &table;
}
