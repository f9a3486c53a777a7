#pragma once
// Exit codes of the command line (documented in README): mapped from the
// library's error codes here only; the libraries report ErrorCode, never exit codes.
#include "tetlod/core/error.hpp"

namespace tetlod {

inline int exit_code_for(ErrorCode code) {
    switch (code) {
        case ErrorCode::Ok: return 0;
        case ErrorCode::InvalidArgument: return 2;
        case ErrorCode::IoError: return 3;
        case ErrorCode::NotFound: return 3;
        case ErrorCode::NotBuilt: return 5;
        default: return 4;  // the input is bad: truncated, corrupt, unsupported, too large
    }
}

}  // namespace tetlod
