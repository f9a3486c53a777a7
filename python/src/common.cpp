// Argument parsing shared by the bindings (see common.hpp).
#include "common.hpp"

#include <cmath>
#include <set>

#include "tetlod/core/error.hpp"
#include "tetlod/core/value_type.hpp"

namespace py = pybind11;

namespace tetlod::python {

ModelKind model_kind(const std::string& name) {
    if (auto kind = parse_model_kind(name)) return *kind;
    throw Error(ErrorCode::InvalidArgument, "model '" + name + "': expected 'ht' or 'mt'");
}

double Threshold::resolve(const std::array<double, 2>& range) const {
    if (!percent || value < 0) return value;
    return value * (range[1] - range[0]) / 100.0;  // multiplied first: 1% of 255 is 2.55
}

Threshold threshold(const py::object& given, double if_none) {
    Threshold t;
    if (given.is_none()) {
        t.value = if_none;
    } else if (py::isinstance<py::str>(given)) {
        std::string text = given.cast<std::string>();
        const bool percent = !text.empty() && text.back() == '%';
        if (percent) text.pop_back();
        if (text == "inf" || text == "unbounded") return t;
        try {
            std::size_t used = 0;
            t.value = std::stod(text, &used);
            if (used != text.size()) throw std::invalid_argument(text);
        } catch (const std::exception&) {
            throw Error(ErrorCode::InvalidArgument,
                        "error threshold '" + given.cast<std::string>() +
                            "': expected a number, a percentage like '1%', or 'inf'");
        }
        t.percent = percent;
    } else {
        t.value = given.cast<double>();
    }
    if (std::isnan(t.value)) throw Error(ErrorCode::InvalidArgument, "error threshold is NaN");
    return t;
}

QueryArgs query_args(const py::object& error, const py::object& error_out, const py::object& box,
                     const py::object& isovalues, bool full, const py::object& regions) {
    if (error.is_none() && !full)
        throw Error(ErrorCode::InvalidArgument,
                    "give error= (e.g. 0.5 or '1%'; negative: full resolution) or full=True");
    QueryArgs q;
    q.error = threshold(error, LodQuery::kUnbounded);
    q.error_out = threshold(error_out, LodQuery::kUnbounded);
    if (!box.is_none()) {
        auto b = box.cast<std::vector<int64_t>>();
        if (b.size() != 6)
            throw Error(ErrorCode::InvalidArgument, "box: expected (x0, y0, z0, x1, y1, z1)");
        q.box = std::array<int64_t, 6>{b[0], b[1], b[2], b[3], b[4], b[5]};
    }
    if (!isovalues.is_none()) {
        if (py::isinstance<py::float_>(isovalues) || py::isinstance<py::int_>(isovalues))
            q.isovalues = {isovalues.cast<double>()};
        else
            q.isovalues = isovalues.cast<std::vector<double>>();
    }
    if (!regions.is_none()) {
        if (!py::isinstance<py::dict>(regions))
            throw Error(ErrorCode::InvalidArgument, "regions: expected a dict {name: parameters}");
        for (const auto& [key, value] : regions.cast<py::dict>()) {
            const std::string name = py::str(key);
            const QueryRegionKind* kind = find_query_region_kind(name);
            if (!kind) {
                std::string known;
                for (const auto& k : query_region_kinds()) {
                    if (!known.empty()) known += ", ";
                    known += k.name;
                }
                throw Error(ErrorCode::InvalidArgument, "regions: no query region '" + name + "' (known: " + known + ")");
            }
            // Text as on the command line; a sequence of numbers is joined by commas.
            std::string text;
            if (py::isinstance<py::str>(value)) {
                text = value.cast<std::string>();
            } else {
                for (const auto& item : value) {
                    if (!text.empty()) text += ',';
                    text += std::string(py::str(item));
                }
            }
            try {
                q.regions.push_back(kind->parse(text));
            } catch (const Error& e) {
                throw Error(e.code(), "regions: " + std::string(e.what()));
            }
        }
    }
    q.full = full;
    return q;
}

LodQuery QueryArgs::resolve(const std::array<double, 2>& range) const {
    LodQuery query;
    query.error_in = error.resolve(range);
    query.error_out = error_out.resolve(range);
    query.box = box;
    query.isovalues = isovalues;
    query.regions = regions;
    query.full = full;
    return query;
}

namespace {
Vec3 vec3(const py::handle& value, const char* what) {
    auto v = value.cast<std::vector<double>>();
    if (v.size() != 3) throw Error(ErrorCode::InvalidArgument, std::string(what) + ": expected 3 numbers");
    return {v[0], v[1], v[2]};
}
}  // namespace

VolumeReadOptions read_options(const py::kwargs& kwargs) {
    VolumeReadOptions o;
    for (auto [key_handle, value] : kwargs) {
        const std::string key = py::str(key_handle);
        if (value.is_none()) continue;
        if (key == "dims") {
            auto d = value.cast<std::vector<int64_t>>();
            if (d.size() != 3) throw Error(ErrorCode::InvalidArgument, "dims: expected (x, y, z)");
            o.dims = Dims{d[0], d[1], d[2]};
        } else if (key == "dtype") {
            const std::string name = py::str(value);
            o.type = parse_value_type(name);
            if (!o.type)
                throw Error(ErrorCode::InvalidArgument,
                            "dtype '" + name + "': expected u8|i8|u16|i16|u32|i32|f32|f64");
        } else if (key == "endian") {
            const std::string e = py::str(value);
            if (e != "little" && e != "big")
                throw Error(ErrorCode::InvalidArgument, "endian '" + e + "': expected little or big");
            o.endian = e == "big" ? Endian::Big : Endian::Little;
        } else if (key == "header_bytes") {
            o.header_bytes = value.cast<uint64_t>();
        } else if (key == "spacing") {
            o.spacing = vec3(value, "spacing");
        } else if (key == "origin") {
            o.origin = vec3(value, "origin");
        } else if (key == "grid") {
            o.grid = py::str(value);
        } else if (key == "axis_order") {
            o.axis_order = py::str(value);
        } else if (key == "allow_external_data") {
            o.allow_external_data = value.cast<bool>();
        } else {
            throw Error(ErrorCode::InvalidArgument,
                        "unknown keyword '" + key + "' (volume options: dims, dtype, endian, "
                        "header_bytes, spacing, origin, grid, axis_order, allow_external_data)");
        }
    }
    return o;
}

py::object json_to_python(const std::string& json_text) {
    return py::module_::import("json").attr("loads")(json_text);
}

}  // namespace tetlod::python
