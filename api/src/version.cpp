// Library and container-format versions (see version.hpp).
#include "tetlod/version.hpp"

#include "tetlod/format/container.hpp"

namespace tetlod {

const char* library_version() { return TETLOD_LIBRARY_VERSION_STRING; }
const char* format_version() { return tlod::format_version_string(); }

}  // namespace tetlod
