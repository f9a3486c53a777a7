// Models and their queries from Python: tetlod.Model (an HT or MT in memory,
// opened from a container or built from a volume file), and the one-call forms
// extract / isosurface / stats on a path. Long calls release the GIL.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "common.hpp"
#include "tetlod/analysis/model_stats.hpp"
#include "tetlod/container.hpp"
#include "tetlod/model.hpp"

namespace py = pybind11;

namespace tetlod::python {
namespace {

/// model=None: choose_model's default (a container's only model, else the HT).
ModelKind choose_model(const py::object& model, const std::string& path) {
    std::optional<ModelKind> requested;
    if (!model.is_none()) requested = model_kind(model.cast<std::string>());
    return tetlod::choose_model(path, requested);
}

LodModel open_path(const std::string& path, const py::object& model, bool pad, const py::kwargs& kwargs) {
    const VolumeReadOptions read = read_options(kwargs);
    const ModelKind kind = choose_model(model, path);
    ModelBuildOptions build;
    build.pad = pad;
    py::gil_scoped_release release;
    return open_model(path, kind, read, build).take();
}

py::object mesh_object(TetMesh&& mesh, const LodModel& model, const LodExtractStats& stats) {
    py::object out = py::cast(std::move(mesh));
    out.attr("model") = model_kind_name(model.kind);
    out.attr("range") = py::make_tuple(model.range[0], model.range[1]);
    out.attr("max_error") = stats.max_error;
    return out;
}

py::object model_extract(const LodModel& model, const QueryArgs& args) {
    const LodQuery query = args.resolve(model.range);
    LodExtractStats stats;
    TetMesh mesh = [&] {
        py::gil_scoped_release release;
        return model.extract(query, &stats);
    }();
    return mesh_object(std::move(mesh), model, stats);
}

py::object model_isosurface(const LodModel& model, const QueryArgs& args) {
    LodQuery query = args.resolve(model.range);
    if (args.isovalues.empty())
        throw Error(ErrorCode::InvalidArgument, "isosurface: give isovalues= (one or more values)");
    TriangleMesh surface = [&] {
        py::gil_scoped_release release;
        return model.isosurface(query, args.isovalues);
    }();
    return py::cast(std::move(surface));
}

py::object model_stats(const LodModel& model, const py::object& error_fractions,
                       const py::object& isovalues) {
    StatsOptions options;
    if (!error_fractions.is_none()) options.error_fractions = error_fractions.cast<std::vector<double>>();
    if (!isovalues.is_none()) options.isovalues = isovalues.cast<std::vector<double>>();
    std::string text;
    {
        py::gil_scoped_release release;
        ModelStats stats = measure_model(model, model_kind_name(model.kind), options);
        text = stats_json({stats}).dump();
    }
    py::object parsed = json_to_python(text);
    if (py::isinstance<py::list>(parsed) && py::len(parsed) == 1) return parsed[py::int_(0)];
    return parsed;
}

void bind_model_class(py::module_& m) {
    py::class_<LodModel>(m, "Model", "An HT or MT in memory; its queries are thread-safe.")
        .def_property_readonly("kind", [](const LodModel& lm) { return std::string(model_kind_name(lm.kind)); })
        .def_property_readonly("dims", [](const LodModel& lm) {
            return py::make_tuple(lm.dims.x, lm.dims.y, lm.dims.z);
        })
        .def_property_readonly("range", [](const LodModel& lm) { return py::make_tuple(lm.range[0], lm.range[1]); })
        .def_readonly("updates", &LodModel::updates)
        .def_readonly("memory_bytes", &LodModel::memory_bytes)
        .def_readonly("stored_bytes", &LodModel::stored_bytes)
        .def_readonly("build_seconds", &LodModel::build_seconds)
        .def_readonly("from_container", &LodModel::from_container)
        // A lossy container's bound (every sample within it of the original;
        // thresholds below it give the full mesh), 0.0 when lossless.
        .def_readonly("field_max_error", &LodModel::field_error)
        .def(
            "extract",
            [](const LodModel& lm, py::object error, py::object error_out, py::object box,
               py::object isovalues, bool full, py::object regions) {
                return model_extract(lm, query_args(error, error_out, box, isovalues, full, regions));
            },
            py::arg("error") = py::none(), py::arg("error_out") = py::none(),
            py::arg("box") = py::none(), py::arg("isovalues") = py::none(), py::arg("full") = false,
            py::arg("regions") = py::none(),
            "The LOD mesh of a query: error (field units, '1%' of the range, 'inf'; negative: full "
            "resolution) inside the region, error_out elsewhere; region = box (x0,y0,z0,x1,y1,z1 "
            "inclusive, index space) and/or isovalues and/or regions ({'sphere': (cx, cy, cz, r)}, any "
            "kind in tetlod.query_regions()); full=True: the reference mesh.")
        .def(
            "isosurface",
            [](const LodModel& lm, py::object isovalues, py::object error, bool full) {
                return model_isosurface(lm, query_args(error, py::none(), py::none(), isovalues, full));
            },
            py::arg("isovalues"), py::arg("error") = -1.0, py::arg("full") = false,
            "Marching tetrahedra on the mesh of error (default: full resolution) for each isovalue.")
        .def("stats", &model_stats, py::arg("error_fractions") = py::none(),
             py::arg("isovalues") = py::none(),
             "What `tetlod stats --json` measures (tets vs error, queries, quality), as a dict.")
        .def("__repr__", [](const LodModel& lm) {
            return "<tetlod.Model " + std::string(model_kind_name(lm.kind)) + " " +
                   std::to_string(lm.dims.x) + "x" + std::to_string(lm.dims.y) + "x" +
                   std::to_string(lm.dims.z) + ">";
        });
}

}  // namespace

void bind_models(py::module_& m) {
    bind_model_class(m);
    m.def(
        "query_regions",
        [] {
            py::dict out;
            for (const auto& k : query_region_kinds()) out[py::str(k.name)] = k.syntax + ": " + k.help;
            return out;
        },
        "The query regions extract(regions=...) takes: {name: 'syntax: description'}.");
    m.def("open", &open_path, py::arg("path"), py::arg("model") = py::none(), py::arg("pad") = false,
          "The model of a path: a .tlod container's stored HT or MT, or a volume file read and "
          "built (model 'ht' or 'mt'; volume keywords as for read_volume). Safe on untrusted files.");
    m.def(
        "extract",
        [](const std::string& path, py::object model, py::object error, py::object error_out,
           py::object box, py::object isovalues, bool full, bool pad, py::object regions, py::kwargs kwargs) {
            const QueryArgs args = query_args(error, error_out, box, isovalues, full, regions);
            const ModelKind kind = choose_model(model, path);
            if (!is_container_path(path)) return model_extract(open_path(path, py::cast(model_kind_name(kind)), pad, kwargs), args);
            if (py::len(kwargs) != 0 || pad)
                throw Error(ErrorCode::InvalidArgument,
                            path + ": volume options (pad, dims, ...) do not apply to a container");
            ContainerExtract x = [&] {
                py::gil_scoped_release release;
                return extract_from_container(path, kind, LodQuery{},
                                              [&](LodQuery& q, const std::array<double, 2>& range) {
                                                  q = args.resolve(range);
                                              })
                    .take();
            }();
            py::object out = py::cast(std::move(x.mesh));
            out.attr("model") = model_kind_name(x.model);
            out.attr("range") = py::make_tuple(x.range[0], x.range[1]);
            out.attr("max_error") = x.max_error;
            // A lossy container's E: no tet's bound (max_error included) is below it.
            out.attr("field_max_error") = x.field_max_error;
            out.attr("bytes_read") = x.bytes_read;
            out.attr("distinct_bytes_read") = x.distinct_bytes_read;
            return out;
        },
        py::arg("path"), py::arg("model") = py::none(), py::arg("error") = py::none(),
        py::arg("error_out") = py::none(), py::arg("box") = py::none(),
        py::arg("isovalues") = py::none(), py::arg("full") = false, py::arg("pad") = false,
        py::arg("regions") = py::none(),
        "The LOD mesh of a query on a .tlod container (the HT read lazily) or a volume file "
        "(model built first). Query arguments as for Model.extract; returns a Mesh.");
    m.def(
        "isosurface",
        [](const std::string& path, py::object isovalues, py::object model, py::object error,
           bool full, py::kwargs kwargs) {
            return model_isosurface(open_path(path, model, false, kwargs),
                                    query_args(error, py::none(), py::none(), isovalues, full));
        },
        py::arg("path"), py::arg("isovalues"), py::arg("model") = py::none(),
        py::arg("error") = -1.0, py::arg("full") = false,
        "Isosurfaces of a container or volume file as a Surface (triangles as numpy arrays).");
    m.def(
        "stats",
        [](const std::string& path, py::object model, py::object error_fractions,
           py::object isovalues, py::kwargs kwargs) {
            return model_stats(open_path(path, model, false, kwargs), error_fractions, isovalues);
        },
        py::arg("path"), py::arg("model") = py::none(), py::arg("error_fractions") = py::none(),
        py::arg("isovalues") = py::none(), "Model statistics (as `tetlod stats --json`) as a dict.");
}

}  // namespace tetlod::python
