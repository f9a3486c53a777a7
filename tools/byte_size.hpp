#pragma once
// "512M", "2G", "1.5GiB", "1073741824" -> bytes: the --memory syntax, shared by
// `tetlod` (cli_common's parse_byte_size) and `tetlod-mpi`. Standard library
// only: tools/ includes only "tetlod/tetlod.hpp", which tetlod-mpi cannot use.
#include <cstddef>
#include <optional>
#include <string>

namespace tetlod::cli {

/// K/M/G/T are powers of 1024, optionally followed by "B" or "iB". nullopt
/// with `why` set when `text` is not such a size.
std::optional<std::size_t> byte_size_from(const std::string& text, std::string& why);

}  // namespace tetlod::cli
