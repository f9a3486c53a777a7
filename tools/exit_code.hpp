#pragma once
// Exit codes of the command line (documented in README): mapped from the
// library's error codes here only; the libraries report ErrorCode, never exit codes.
//
// A template over the code type so that this header includes nothing: tools/
// includes only "tetlod/tetlod.hpp" (tests/api/tools_use_public_api.cmake), and
// tetlod-mpi, which must not see the serial converters, uses the same table
// with "tetlod/core/error.hpp".

namespace tetlod {

template <class Code>
int exit_code_for(Code code) {
    switch (code) {
        case Code::Ok: return 0;
        case Code::InvalidArgument: return 2;
        case Code::IoError: return 3;
        case Code::NotFound: return 3;
        case Code::NotBuilt: return 5;
        default: return 4;  // the input is bad: truncated, corrupt, unsupported, too large
    }
}

}  // namespace tetlod
