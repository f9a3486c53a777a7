// Volumes as numpy arrays: read any supported volume file (no copy of the
// samples: the array owns the C++ buffer), write an array to any volume format,
// and the built-in sample volumes. Arrays are indexed [z, y, x] (x fastest).
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "common.hpp"
#include "tetlod/converters/sample_volumes.hpp"
#include "tetlod/converters/volume_formats.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/value_type.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/model.hpp"

namespace py = pybind11;

namespace tetlod::python {
namespace {

py::dtype numpy_dtype(ValueType type) {
    return dispatch_value_type(type, [](auto tag) {
        using T = decltype(tag);
        return py::dtype::of<T>();
    });
}

ValueType value_type_of_dtype(const py::dtype& dtype) {
    const ValueType types[] = {ValueType::U8,  ValueType::I8,  ValueType::U16, ValueType::I16,
                               ValueType::U32, ValueType::I32, ValueType::F32, ValueType::F64};
    for (ValueType t : types)
        if (numpy_dtype(t).equal(dtype)) return t;
    throw Error(ErrorCode::InvalidArgument,
                "array dtype " + dtype.attr("name").cast<std::string>() +
                    ": expected uint8, int8, uint16, int16, uint32, int32, float32 or float64");
}

void write_volume_array(py::array array, const std::string& path, py::object spacing,
                        py::object origin, const std::string& field_name, const std::string& format) {
    if (array.ndim() != 3)
        throw Error(ErrorCode::InvalidArgument, path + ": volume array must have 3 axes (z, y, x)");
    const ValueType type = value_type_of_dtype(array.dtype());
    // A C-contiguous little-endian copy is what the writers expect.
    py::array contiguous = py::array::ensure(array, py::array::c_style | py::array::forcecast);
    Volume volume = Volume::allocate(Dims{array.shape(2), array.shape(1), array.shape(0)}, type);
    std::memcpy(volume.data.data(), contiguous.data(), volume.data.size());
    if (!spacing.is_none()) volume.spacing = spacing.cast<Vec3>();
    if (!origin.is_none()) volume.origin = origin.cast<Vec3>();
    volume.field_name = field_name;
    py::gil_scoped_release release;
    write_volume(volume, path, format);
}

}  // namespace

py::array volume_array(Volume&& volume) {
    auto owned = std::make_unique<ZeroedVector<std::byte>>(std::move(volume.data));
    const std::size_t size = value_size(volume.type);
    const Dims d = volume.dims;
    std::byte* data = owned->data();
    py::capsule owner(owned.get(), [](void* p) { delete static_cast<ZeroedVector<std::byte>*>(p); });
    owned.release();
    return py::array(numpy_dtype(volume.type), {d.z, d.y, d.x},
                     {py::ssize_t(size) * d.x * d.y, py::ssize_t(size) * d.x, py::ssize_t(size)},
                     data, owner);
}

void bind_volumes(py::module_& m) {
    m.def(
        "read_volume",
        [](const std::string& path, py::kwargs kwargs) {
            const VolumeReadOptions options = read_options(kwargs);
            Volume volume = [&] {
                py::gil_scoped_release release;
                return read_volume_file(path, options).take();
            }();
            return volume_array(std::move(volume));
        },
        py::arg("path"),
        "Reads a volume file (raw, NRRD, MetaImage, OpenVDB, FILE.h5:/dataset) into a numpy "
        "array indexed [z, y, x]. Keywords: dims=(x, y, z), dtype='u8'.., endian, header_bytes, "
        "spacing, origin, grid, axis_order, allow_external_data. Safe on untrusted files.");
    m.def("write_volume", &write_volume_array, py::arg("array"), py::arg("path"),
          py::arg("spacing") = py::none(), py::arg("origin") = py::none(),
          py::arg("field_name") = "value", py::arg("format") = "",
          "Writes a 3-axis numpy array [z, y, x] as a volume file (format from the extension: "
          ".raw, .nrrd, .nhdr, .mhd, .mha, .vdb, FILE.h5:/dataset).");
    m.def(
        "sample_volume",
        [](const std::string& name, std::array<int64_t, 3> dims, const std::string& dtype) {
            auto type = parse_value_type(dtype);
            if (!type) throw Error(ErrorCode::InvalidArgument, "dtype '" + dtype + "' is unknown");
            return volume_array(make_sample_volume(name, Dims{dims[0], dims[1], dims[2]}, *type));
        },
        py::arg("name"), py::arg("dims"), py::arg("dtype") = "u8",
        "A built-in analytic volume (see sample_volume_names()) as a numpy array [z, y, x].");
    m.def("sample_volume_names", &sample_volume_names);
}

}  // namespace tetlod::python
