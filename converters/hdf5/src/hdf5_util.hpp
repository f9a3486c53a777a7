#pragma once
// Small HDF5 helpers shared by the reader, the plane reader and the writer:
// identifier ownership, the library's error text, names and type mapping.
// Private to tetlod_hdf5_io.
#include <hdf5.h>

#include <set>
#include <string>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::hdf5_detail {

// Owns an HDF5 identifier; closes it with the matching function.
class Hid {
public:
    Hid() = default;
    Hid(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
    Hid(Hid&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
    Hid& operator=(Hid&& o) noexcept {
        reset();
        id_ = o.id_;
        close_ = o.close_;
        o.id_ = -1;
        return *this;
    }
    ~Hid() { reset(); }
    void reset() {
        if (id_ >= 0 && close_) close_(id_);
        id_ = -1;
    }
    hid_t get() const { return id_; }
    bool valid() const { return id_ >= 0; }

private:
    hid_t id_ = -1;
    herr_t (*close_)(hid_t) = nullptr;
};

/// The library prints its error stack to stderr by default; tetlod reports
/// errors itself, so printing is switched off (per thread, call it first).
void silence_hdf5();
/// The innermost message of the library's error stack (cleared).
std::string hdf5_error_text();
/// Shortest text that reads back as `v`.
std::string num_text(double v);
/// "'file:dataset'" for messages.
std::string name_of(const std::string& file, const std::string& dataset);
/// "" -> "/volume"; "a/b" -> "/a/b".
std::string normalize_dataset(const std::string& d);
/// In-memory type of a volume's samples (host order).
hid_t native_type(ValueType t);
/// File type of a volume's samples in byte order `e`.
hid_t file_type(ValueType t, Endian e);
/// Attributes the reader turns into Volume fields; the writer owns these names.
const std::set<std::string>& structural_attributes();

}  // namespace tetlod::hdf5_detail
