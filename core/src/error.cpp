#include "tetlod/core/error.hpp"

namespace tetlod {

const char* error_code_name(ErrorCode code) {
    switch (code) {
        case ErrorCode::Ok: return "ok";
        case ErrorCode::InvalidArgument: return "invalid argument";
        case ErrorCode::IoError: return "I/O error";
        case ErrorCode::Truncated: return "truncated input";
        case ErrorCode::BadMagic: return "bad magic";
        case ErrorCode::UnsupportedVersion: return "unsupported version";
        case ErrorCode::UnsupportedFeature: return "unsupported feature";
        case ErrorCode::ChecksumMismatch: return "checksum mismatch";
        case ErrorCode::CorruptData: return "corrupt data";
        case ErrorCode::SizeMismatch: return "size mismatch";
        case ErrorCode::TooLarge: return "too large";
        case ErrorCode::NotFound: return "not found";
        case ErrorCode::NotBuilt: return "not built";
    }
    return "unknown error";
}

}  // namespace tetlod
