#pragma once
// Inputs that must be regular files. Opening a FIFO for reading blocks until a
// writer appears (forever, for a FIFO nobody writes to), and a character device
// such as /dev/zero never ends: a reader that needs a file's size or a seekable
// byte range asks this first, before it opens the path.
#include <optional>
#include <string>

#include "tetlod/core/error.hpp"

namespace tetlod {

/// Throws tetlod::Error unless `path` (after following symlinks) is a regular
/// file: IoError "no such file" when it is missing, IoError naming the kind
/// (FIFO, directory, device, socket) otherwise. `what` names the role in the
/// message ("NRRD data file", "HDF5 file", ...). The literal path "-" (stdin,
/// handled by the callers that can stream) is let through unchecked.
void require_regular_file(const std::string& path, const std::string& what = "input file");

/// The same check for code that returns Expected: the failure, or nothing.
std::optional<Failure> regular_file_failure(const std::string& path, const std::string& what = "input file");

}  // namespace tetlod
