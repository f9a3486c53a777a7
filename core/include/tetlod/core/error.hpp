#pragma once
// Errors: every failure the user can cause (bad files, bad flags) is reported as
// a tetlod::Error carrying a code and a message that names the file and the problem.
// Code that parses untrusted bytes returns Expected<T> instead of throwing, so a
// decoder can never "throw through" half-built state.
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

namespace tetlod {

enum class ErrorCode {
    Ok = 0,
    InvalidArgument,   // a flag or parameter is wrong
    IoError,           // open/read/write/rename failed
    Truncated,         // input ends before the structure it declares
    BadMagic,          // not a file of the expected kind
    UnsupportedVersion,
    UnsupportedFeature,
    ChecksumMismatch,
    CorruptData,       // structurally invalid content
    SizeMismatch,      // file size does not match declared dims x type
    TooLarge,          // declared sizes exceed sane limits
    NotFound,          // missing dataset/grid/section
    NotBuilt,          // feature disabled at build time
};

const char* error_code_name(ErrorCode code);

/// Exit code of the command line for an error code (documented in README).
int exit_code_for(ErrorCode code);

class Error : public std::runtime_error {
public:
    Error(ErrorCode code, const std::string& message)
        : std::runtime_error(message), code_(code) {}
    ErrorCode code() const { return code_; }

private:
    ErrorCode code_;
};

struct Failure {
    ErrorCode code;
    std::string message;
};

/// Minimal expected<T, Failure> (std::expected is C++23).
template <class T>
class Expected {
public:
    Expected(T value) : v_(std::move(value)) {}
    Expected(Failure f) : v_(std::move(f)) {}
    bool ok() const { return v_.index() == 0; }
    explicit operator bool() const { return ok(); }
    T& value() { return std::get<0>(v_); }
    const T& value() const { return std::get<0>(v_); }
    T& operator*() { return value(); }
    const T& operator*() const { return value(); }
    T* operator->() { return &value(); }
    const T* operator->() const { return &value(); }
    const Failure& failure() const { return std::get<1>(v_); }
    /// Returns the value or throws the failure as tetlod::Error.
    T take() {
        if (!ok()) throw Error(failure().code, failure().message);
        return std::move(value());
    }

private:
    std::variant<T, Failure> v_;
};

inline Failure fail(ErrorCode code, std::string message) { return Failure{code, std::move(message)}; }

}  // namespace tetlod
