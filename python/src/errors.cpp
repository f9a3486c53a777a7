// tetlod::Error (a bad file, a bad argument) surfaces in Python as tetlod.Error,
// a RuntimeError whose message names the file and the problem, with the error
// code's name in `.code` (e.g. "Truncated", "NotFound").
#include "bindings.hpp"
#include "tetlod/core/error.hpp"

namespace py = pybind11;

namespace tetlod::python {
namespace {

/// The code as a Python identifier (error_code_name gives prose, "I/O error").
/// No default: -Wswitch flags a code added to ErrorCode and missing here.
const char* code_identifier(ErrorCode code) {
    switch (code) {
        case ErrorCode::Ok: return "Ok";
        case ErrorCode::InvalidArgument: return "InvalidArgument";
        case ErrorCode::IoError: return "IoError";
        case ErrorCode::Truncated: return "Truncated";
        case ErrorCode::BadMagic: return "BadMagic";
        case ErrorCode::UnsupportedVersion: return "UnsupportedVersion";
        case ErrorCode::UnsupportedFeature: return "UnsupportedFeature";
        case ErrorCode::ChecksumMismatch: return "ChecksumMismatch";
        case ErrorCode::CorruptData: return "CorruptData";
        case ErrorCode::SizeMismatch: return "SizeMismatch";
        case ErrorCode::TooLarge: return "TooLarge";
        case ErrorCode::NotFound: return "NotFound";
        case ErrorCode::NotBuilt: return "NotBuilt";
    }
    return "Unknown";
}

}  // namespace

void bind_errors(py::module_& m) {
    // Leaked on purpose: the exception type lives as long as the interpreter.
    static py::handle error_type = py::exception<Error>(m, "Error", PyExc_RuntimeError).release();
    m.attr("Error").attr("__module__") = "tetlod";
    m.attr("Error").attr("__doc__") =
        "A tetlod failure: the message names the file and the problem; .code names the kind "
        "(InvalidArgument, IoError, Truncated, BadMagic, CorruptData, NotFound, NotBuilt, ...).";
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const Error& e) {
            py::object instance = py::reinterpret_borrow<py::object>(error_type)(e.what());
            instance.attr("code") = code_identifier(e.code());
            PyErr_SetObject(error_type.ptr(), instance.ptr());
        }
    });
}

}  // namespace tetlod::python
