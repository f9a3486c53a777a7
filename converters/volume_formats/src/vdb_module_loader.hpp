#pragma once
// Finds and loads the OpenVDB converter module (tetlod/converters/vdb_module.hpp)
// the first time a .vdb file is read or written.
#include "tetlod/converters/vdb_module.hpp"

namespace tetlod {

/// The module's table, loaded once per process. Throws Error(NotBuilt) naming
/// every place looked at when the module cannot be loaded.
const VdbModuleV1& vdb_module();

}  // namespace tetlod
