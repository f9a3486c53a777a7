// .tlod containers from Python: what one holds (info, models), writing one from
// a volume file (convert), decoding its volume back (decode), and checking it
// (verify).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "common.hpp"
#include "tetlod/analysis/container_verify.hpp"
#include "tetlod/codecs/lossy_field.hpp"
#include "tetlod/container.hpp"
#include "tetlod/converters/volume_formats.hpp"
#include "tetlod/core/value_type.hpp"
#include "tetlod/model.hpp"

namespace py = pybind11;

namespace tetlod::python {
namespace {

/// The report of `tetlod verify` as a dict. A stage's flag (checksums_ok, mt/ht "ok",
/// "deep_ok") is True only when it ran and passed; `failure` is the first problem, and
/// no stage after it ran. The deep keys are there only when deep checks were asked for.
py::dict verify_dict(const VerifyReport& r, bool deep) {
    py::dict d;
    d["path"] = r.path;
    d["ok"] = r.ok();
    d["deep"] = deep;
    d["failure"] = py::none();
    if (r.failure) {
        py::dict f;
        f["code"] = error_code_name(r.failure->code);
        f["message"] = r.failure->message;
        d["failure"] = f;
    }
    d["checksums_ok"] = r.checksums_ok;
    d["sections"] = r.sections;
    py::list models;
    if (r.has_ht) models.append("ht");
    if (r.has_mt) models.append("mt");
    d["models"] = models;
    d["max_error"] = r.max_error;
    if (r.has_mt) {
        py::dict mt;
        mt["ok"] = r.mt_ok;
        mt["updates"] = r.mt_updates;
        mt["tets_at_error0"] = r.mt_tets_at_error0;
        if (deep) {
            mt["deep_ok"] = r.mt_deep_ok;
            mt["reference_tets"] = r.mt_reference_tets;
            mt["bounds_checked"] = r.mt_bounds_checked;
            mt["bounds_unchecked"] = r.mt_bounds_unchecked;
            mt["worst_bound_ratio"] = r.mt_worst_bound_ratio;
        }
        d["mt"] = mt;
    }
    if (r.has_ht) {
        py::dict ht;
        ht["ok"] = r.ht_ok;
        ht["chunks_decoded"] = r.ht_chunks_decoded;
        if (deep) {
            ht["deep_ok"] = r.ht_deep_ok;
            ht["bounds_checked"] = r.ht_bounds_checked;
            ht["bounds_unchecked"] = r.ht_bounds_unchecked;
            ht["worst_bound_ratio"] = r.ht_worst_bound_ratio;
        }
        d["ht"] = ht;
    }
    return d;
}

py::dict info_dict(const ContainerInfo& info) {
    py::dict d;
    d["path"] = info.path;
    d["format_version"] = std::to_string(info.header.version_major) + "." +
                          std::to_string(info.header.version_minor);
    d["file_size"] = info.header.file_size;
    d["bytes_read"] = info.bytes_read;
    const auto& meta = info.metadata;
    d["dims"] = py::make_tuple(meta.dims.x, meta.dims.y, meta.dims.z);
    d["dtype"] = value_type_name(meta.type);
    d["spacing"] = py::make_tuple(meta.spacing[0], meta.spacing[1], meta.spacing[2]);
    d["origin"] = py::make_tuple(meta.origin[0], meta.origin[1], meta.origin[2]);
    d["range"] = py::make_tuple(meta.value_range[0], meta.value_range[1]);
    d["field_name"] = meta.field_name();
    d["units"] = meta.units();
    d["metadata"] = meta.user_keys;
    d["format_keys"] = meta.format_keys;
    py::list models;
    if (info.ht) {
        models.append("ht");
        py::dict ht;
        ht["k"] = info.ht->k;
        ht["max_level"] = info.ht->max_level;
        ht["padded"] = info.ht->padded;
        ht["brick_log2"] = info.ht->brick_log2;
        ht["error_mantissa_bits"] = info.ht->error_mantissa_bits;
        ht["section_bytes"] = info.ht->section_bytes;
        d["ht"] = ht;
    }
    if (info.mt) {
        models.append("mt");
        py::dict mt;
        mt["base_tets"] = info.mt->base_tets;
        mt["updates"] = info.mt->updates;
        mt["field_from_ht"] = info.mt->field_from_ht;
        mt["section_bytes"] = info.mt->section_bytes;
        d["mt"] = mt;
    }
    d["models"] = models;
    d["sections"] = info.sections.size();
    // Where the bytes go, as `tetlod info`: one row per section type and coder.
    py::list coders;
    for (const SectionCoderInfo& c : info.coders) {
        py::dict row;
        row["type"] = c.section;
        row["coder"] = c.coder;
        row["mode"] = c.mode;
        row["count"] = c.count;
        row["empty"] = c.empty;
        row["stored_bytes"] = c.stored_bytes;
        row["raw_bytes"] = c.raw_bytes;
        coders.append(row);
    }
    d["coders"] = coders;
    return d;
}

py::dict convert(const std::string& input, const std::string& output, bool ht, bool mt, bool pad,
                 std::optional<int> zstd_level, const py::object& max_error,
                 std::optional<std::int64_t> memory_bytes, std::optional<int> brick_log2,
                 std::optional<int> error_bits, bool fast_decode, py::kwargs kwargs) {
    const VolumeReadOptions read = read_options(kwargs);
    // Lossy archival (format 3.1, 3.5 with the MT): a number in field units or
    // '1%' of the value range, as the CLI's --max-error; None or 0: lossless.
    const Threshold lossy = threshold(max_error, 0.0);
    if (!(lossy.value >= 0) || !std::isfinite(lossy.value))
        throw Error(ErrorCode::InvalidArgument, "max_error: expected a finite bound >= 0 (0 or None: lossless)");
    if (memory_bytes && *memory_bytes <= 0)
        throw Error(ErrorCode::InvalidArgument, "memory_bytes: expected a positive number of bytes (None: a quarter of RAM)");
    ContainerWriteOptions options;
    if (memory_bytes) options.memory_bytes = std::size_t(*memory_bytes);
    options.ht = ht;
    options.mt = mt;
    options.pad = pad;
    // A level given is the level of every frame (as the CLI's --level); none:
    // the library's default (19, 12 for the MT's streams above 1 MiB).
    if (zstd_level) options.zstd_level = options.mt_large_stream_zstd_level = *zstd_level;
    // None: the library's defaults (automatic bricks, 4 error bits), as the CLI's.
    if (brick_log2) options.brick_log2 = *brick_log2;
    if (error_bits) options.error_bits = *error_bits;
    options.fast_decode = fast_decode;
    options.source_path = input;
    options.converter = "tetlod (Python)";
    ContainerWriteSummary summary;
    {
        py::gil_scoped_release release;
        // As `tetlod convert`: a format that reads planes is handed over as
        // planes, so the HT alone is written in memory bounded by the budget,
        // not by the volume (the library reads them whole for the MT, or for a
        // lossy field that fits the budget); other formats are read whole.
        if (std::unique_ptr<VolumePlanes> planes = open_volume_planes(input, read)) {
            // "P%": one more read of the planes, as the CLI's.
            options.max_error = lossy.value > 0 && lossy.percent ? lossy.resolve(planes_value_range(*planes))
                                                                  : lossy.resolve({0, 0});
            summary = write_container(*planes, output, options);
        } else {
            Volume volume = read_volume_file(input, read).take();
            options.max_error = lossy.resolve(volume.range());
            summary = write_container(std::move(volume), output, options);
        }
    }
    py::dict d;
    d["path"] = output;
    d["bytes"] = summary.bytes;
    d["seconds"] = summary.seconds;
    d["max_error"] = summary.max_error;  // the bound stated (0: the lossless file was written)
    if (summary.ht_k >= 0) {
        d["ht_k"] = summary.ht_k;
        d["ht_max_level"] = summary.ht_max_level;
    }
    if (mt) {
        d["mt_updates"] = summary.mt_updates;
        d["mt_base_tets"] = summary.mt_base_tets;
    }
    return d;
}

}  // namespace

void bind_containers(py::module_& m) {
    m.def(
        "info",
        [](const std::string& path) {
            ContainerInfo info = [&] {
                py::gil_scoped_release release;
                return inspect_container(path).take();
            }();
            return info_dict(info);
        },
        py::arg("path"),
        "What a .tlod container holds: dims, dtype, range, metadata, models ('ht', 'mt') and "
        "their headers. Reads no field data; safe on untrusted files.");
    m.def(
        "models",
        [](const std::string& path) {
            const ContainerModels models = container_models(path);
            py::list out;
            if (models.ht) out.append("ht");
            if (models.mt) out.append("mt");
            return out;
        },
        py::arg("path"), "The models a container holds (empty when it cannot be opened).");
    m.def("is_container", &is_container_path, py::arg("path"),
          "True when path names a .tlod container (by its first bytes, or its extension).");
    m.def("convert", &convert, py::arg("input"), py::arg("output"), py::arg("ht") = true,
          py::arg("mt") = false, py::arg("pad") = false, py::arg("zstd_level") = py::none(),
          py::arg("max_error") = py::none(), py::arg("memory_bytes") = py::none(),
          py::arg("brick_log2") = py::none(), py::arg("error_bits") = py::none(),
          py::arg("fast_decode") = false,
          "Converts a volume file into a .tlod container holding the HT and/or the MT. "
          "max_error: None (lossless), a bound in field units or '1%' of the value range: every "
          "stored sample within it of the original, every error bound stated against the "
          "original (the HT, or the HT and the MT; not the MT alone). memory_bytes: what the "
          "conversion plans for (None: a quarter of RAM); the HT alone is then converted plane by "
          "plane from raw, NRRD, MetaImage, HDF5 and OpenVDB files, in that memory whatever the "
          "volume's size. brick_log2: HT bricks of 2^(t+1+N) grid steps at cycle t (None or 0: "
          "automatic, 5 up to 129 samples per axis, else 4), as the CLI's --brick-log2; error_bits: "
          "mantissa bits of the HT's stored bounds (None: 4), as --error-bits; fast_decode: code the "
          "HT's field for decoding speed (format 3.7, larger), as --fast-decode. "
          "Volume keywords as for read_volume. Returns a summary dict (max_error: "
          "the bound stated, 0 when lossless).");
    m.def(
        "decode",
        [](const std::string& path) {
            Volume volume = [&] {
                py::gil_scoped_release release;
                return decode_container(path).take();
            }();
            return volume_array(std::move(volume));
        },
        py::arg("path"), "The volume a container stores (bit-exact), as a numpy array [z, y, x].");
    m.def(
        "verify",
        [](const std::string& path, bool deep) {
            const VerifyReport report = [&] {
                py::gil_scoped_release release;
                return verify_container(path, deep);
            }();
            return verify_dict(report, deep);
        },
        py::arg("path"), py::arg("deep") = false,
        "Checks a container as `tetlod verify` does: every checksum and structural rule, each "
        "model decoded (the MT also extracted). deep=True also recomputes every stored error "
        "bound from the decoded field by brute force (the HT's diamonds, every tet of a full MT "
        "refinement) and checks each bound holds, plus E in a lossy file. Returns a report dict; "
        "a bad file is not an exception: report['ok'] is False and report['failure'] "
        "({'code', 'message'}, naming the file) is the first problem; no stage after it ran, "
        "and each stage's flag (checksums_ok, ['mt']['ok'], ['ht']['deep_ok'], ...) says "
        "whether it ran and passed.");
}

}  // namespace tetlod::python
