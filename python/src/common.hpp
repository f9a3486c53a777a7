#pragma once
// Helpers shared by the bindings: numpy views of C++ arrays (no copies), the
// keyword arguments every query and volume read accepts, model names.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "tetlod/converters/volume_read_options.hpp"
#include "tetlod/models/lod_model.hpp"
#include "tetlod/models/query_region.hpp"
#include "tetlod/models/lod_query.hpp"

namespace tetlod::python {

/// A read-only numpy view of `rows` x `cols` elements at `data` (cols 0: one
/// dimension), kept alive by `owner` (the Python object holding the C++ vector).
template <class T>
pybind11::array view(pybind11::handle owner, const T* data, std::size_t rows, std::size_t cols = 0) {
    std::vector<pybind11::ssize_t> shape{pybind11::ssize_t(rows)};
    if (cols) shape.push_back(pybind11::ssize_t(cols));
    pybind11::array_t<T> array(shape, data, owner);
    array.attr("setflags")(pybind11::arg("write") = false);
    return array;
}

/// "ht"/"mt" (any case); anything else raises tetlod.Error(InvalidArgument).
ModelKind model_kind(const std::string& name);

/// An error threshold as Python gives it: a number (field units; negative: full
/// resolution), a string "1%" (percent of the value range), "inf", or None.
struct Threshold {
    double value = LodQuery::kUnbounded;
    bool percent = false;
    double resolve(const std::array<double, 2>& range) const;
};
Threshold threshold(const pybind11::object& given, double if_none);

/// The LOD query of the keyword arguments (error, error_out, box, isovalues,
/// regions, full), resolved against a value range. Without error and full, error = full
/// resolution is refused: the caller must say what it wants.
struct QueryArgs {
    Threshold error, error_out;
    std::optional<std::array<int64_t, 6>> box;
    std::vector<double> isovalues;
    std::vector<std::shared_ptr<const QueryRegion>> regions;  // registered kinds, by name
    bool full = false;
    LodQuery resolve(const std::array<double, 2>& range) const;
};
/// `regions`: None or a dict {name: text or numbers} of registered query
/// regions (tetlod/models/query_region.hpp), e.g. {"sphere": (32, 32, 32, 10)}.
QueryArgs query_args(const pybind11::object& error, const pybind11::object& error_out,
                     const pybind11::object& box, const pybind11::object& isovalues, bool full,
                     const pybind11::object& regions = pybind11::none());

/// Volume read options from keyword arguments: dims=(x,y,z), dtype="u8".., endian,
/// header_bytes, spacing, origin, grid (OpenVDB), axis_order (HDF5),
/// allow_external_data. An unknown keyword raises tetlod.Error naming it.
VolumeReadOptions read_options(const pybind11::kwargs& kwargs);

/// A dict of keys/values as Python objects (from nlohmann::json's text).
pybind11::object json_to_python(const std::string& json_text);

}  // namespace tetlod::python

namespace tetlod {
struct Volume;
}
namespace tetlod::python {
/// The samples of `volume` (moved in) as a numpy array of shape (z, y, x) and
/// the matching dtype, owning the C++ buffer through a capsule (no copy).
pybind11::array volume_array(Volume&& volume);
}  // namespace tetlod::python
