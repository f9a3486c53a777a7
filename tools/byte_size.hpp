#pragma once
// "512M", "2G", "1.5GiB", "1073741824" -> bytes: the --memory syntax, shared by
// `tetlod` and `tetlod-mpi` (which links no converter, so none of cli_common).
#include <cstddef>
#include <string>

namespace tetlod::cli {

/// K/M/G/T are powers of 1024; `flag` names the option in the error (empty
/// inside CLI11 checks). Throws tetlod::Error(InvalidArgument).
std::size_t parse_byte_size(const std::string& text, const std::string& flag);

}  // namespace tetlod::cli
