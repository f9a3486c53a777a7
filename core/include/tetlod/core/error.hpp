#pragma once
// Errors: every failure the user can cause (bad files, bad flags) is reported as
// a tetlod::Error carrying a code and a message that names the file and the problem.
//
// The discipline below tools/:
// - Code that parses untrusted bytes (container framing, section decoders, the
//   HT/MT codecs, the readers' header parsers) returns Expected<T>: a decoder
//   never "throws through" half-built state, and a caller sees every way the
//   bytes can be wrong in its signature.
// - Everything else (builders, refinement, writers, argument checks, file
//   opening) throws tetlod::Error.
// - At the seams, no hand conversions: Expected::take() (or raise()) turns a
//   Failure into a thrown Error; capture(f) turns a throwing call into an
//   Expected; with_context() prefixes a Failure's message keeping its code.
// - Exit codes are mapped from ErrorCode only by the command line (tools/).
#include <stdexcept>
#include <string>
#include <type_traits>
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

/// Throws the failure as tetlod::Error (same code and message).
[[noreturn]] inline void raise(const Failure& f) { throw Error(f.code, f.message); }

/// The failure with `context` put before its message, keeping its code.
inline Failure with_context(const std::string& context, const Failure& f) {
    return Failure{f.code, context + f.message};
}

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
        if (!ok()) raise(failure());
        return std::move(value());
    }

private:
    std::variant<T, Failure> v_;
};

inline Failure fail(ErrorCode code, std::string message) { return Failure{code, std::move(message)}; }

/// What capture() returns for a call returning void.
struct Done {};

/// Runs `f()` and returns its result; a thrown tetlod::Error becomes the
/// returned Failure (same code, message prefixed by `context`). Other
/// exceptions (std::bad_alloc, logic errors) propagate.
template <class F>
auto capture(F&& f, const std::string& context = {})
    -> Expected<std::conditional_t<std::is_void_v<std::invoke_result_t<F&>>, Done, std::invoke_result_t<F&>>> {
    try {
        if constexpr (std::is_void_v<std::invoke_result_t<F&>>) {
            f();
            return Done{};
        } else {
            return f();
        }
    } catch (const Error& e) {
        return Failure{e.code(), context + e.what()};
    }
}

}  // namespace tetlod
