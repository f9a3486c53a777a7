#pragma once
// The OpenVDB converter as a module loaded on first use. libopenvdb costs
// about 38 ms of dynamic linking (tens of thousands of symbol relocations) in
// every process that links it, which was most of what any `tetlod` command
// cost before doing anything; so the format table reaches tetlod_vdb_io
// through dlopen when a .vdb file is actually read or written. The module
// exports one C function returning this table; the version in its name
// changes whenever the table does.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

struct VdbModuleV1 {
    /// The build's id (CMake's TETLOD_BUILD_ID): the loader refuses a module
    /// from another build (an older install, another build tree), whose
    /// Volume or VolumePlanes may not be laid out like its own.
    const char* build_id;
    Volume (*read)(const std::string& path, const VolumeReadOptions& options);
    std::unique_ptr<VolumePlanes> (*open_planes)(const std::string& path, const VolumeReadOptions& options);
    std::vector<std::pair<std::string, std::string>> (*list_grids)(const std::string& path);
    void (*write)(const Volume& volume, const std::string& path);
    void (*write_planes)(VolumePlanes& planes, const std::string& path);
    std::vector<std::string> (*unstorable_keys)(const Volume& volume);
};

}  // namespace tetlod

/// The module's entry point (the symbol the loader looks up).
extern "C" const tetlod::VdbModuleV1* tetlod_vdb_module_v1();
