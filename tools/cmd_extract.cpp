// tetlod extract: builds the multiresolution model of a volume and writes one
// level-of-detail mesh: uniform (--error), region-driven (--box, --isovalue with
// --error inside and --error-out elsewhere) or the full-resolution reference.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <limits>
#include <ostream>

#include "cli_common.hpp"
#include "command.hpp"
#include "cli_outputs.hpp"
#include "extract_tlod.hpp"
#include "lod_model.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::cli {

namespace {

struct ExtractArgs {
    std::string input, output, model, format;  // empty: not given
    LodFlags lod;
    bool pad = false, no_compress = false;
    VolumeFlags volume;
};

int run_extract(const ExtractArgs& a) {
    const bool mt = resolve_model(a.model, a.input) == "mt";
    if (mt && a.pad)
        throw Error(ErrorCode::InvalidArgument,
                    "--pad applies to the HT only (the MT always covers the data's bounding box): "
                    "drop --pad or use --model ht");
    a.lod.validate(/*need_error=*/true);
    const auto error_in = a.lod.error_in();
    const auto error_out = a.lod.error_out_threshold();

    if (container_input(a.input)) {  // containers: lazy extraction, no model build
        TlodExtractRequest t{a.input, a.output, a.format, {}, {}, {}, !a.no_compress};
        t.model = mt ? "mt" : "ht";
        t.query = a.lod.region_query(nullptr);
        t.error_in = [error_in](const std::array<double, 2>& r) { return error_in.resolve(r); };
        t.error_out = [error_out](const std::array<double, 2>& r) { return error_out.resolve(r); };
        return run_extract_tlod(std::move(t));
    }
    Volume volume = load_volume(a.input, a.volume.options());
    const Dims dims = volume.dims;
    const std::string type_name = value_type_name(volume.type);
    LodQuery query = a.lod.region_query(&dims);

    TetMesh mesh;
    std::array<double, 2> range{0, 0};
    double build_seconds = 0, extract_seconds = 0, max_error = 0;
    std::string model_detail;
    if (mt) {  // MT: built by edge collapse from the volume, same query
        Stopwatch build_clock;
        const MtModel model = MtModel::build(std::move(volume));
        build_seconds = build_clock.seconds();
        range = model.value_range();
        query.error_in = error_in.resolve(range);
        query.error_out = error_out.resolve(range);
        MtExtractStats stats;
        Stopwatch extract_clock;
        mesh = model.extract(query, &stats);
        extract_seconds = extract_clock.seconds();
        max_error = stats.max_error;
        model_detail = "model: MT, " + std::to_string(model.updates().size()) + " vertex splits, " +
                       std::to_string(model.base_tets().size()) + " base tets; " +
                       std::to_string(stats.splits) + " splits applied (" +
                       std::to_string(stats.forced_splits) + " forced), " +
                       std::to_string(stats.visited_tets) + " tets visited";
    } else {
        HtBuildOptions build_options;
        build_options.pad = a.pad;
        Stopwatch build_clock;
        const HtModel model = HtModel::build(std::move(volume), build_options);
        build_seconds = build_clock.seconds();
        range = model.value_range();
        query.error_in = error_in.resolve(range);
        query.error_out = error_out.resolve(range);

        HtExtractStats stats;
        Stopwatch extract_clock;
        mesh = model.extract(query, &stats);
        extract_seconds = extract_clock.seconds();
        max_error = stats.max_error;
        model_detail = "model: HT, cube side 2^" + std::to_string(model.domain().k) +
                       (model.domain().padded ? " (padded)" : "") + ", " +
                       std::to_string(stats.split_diamonds) + " diamonds split, " +
                       std::to_string(stats.visited_tets) + " tets visited";
    }

    MeshWriteOptions write_options;
    write_options.compress = !a.no_compress;
    Stopwatch write_clock;
    write_tet_mesh(mesh, a.output, a.format, write_options);
    const double write_seconds = write_clock.seconds();

    auto& o = out();
    o << "input    " << a.input << ": " << format_dims(dims) << " " << type_name << ", values "
      << format_number(range[0]) << ".." << format_number(range[1]) << "\n";
    o << "query    " << a.lod.describe(query, range) << "\n";
    o << "mesh     " << mesh.tet_count() << " tets, " << mesh.vertex_count()
      << " vertices, largest error " << format_error(max_error, range) << "\n";
    o << "time     build " << format_seconds(build_seconds) << ", extract "
      << format_seconds(extract_seconds) << ", write " << format_seconds(write_seconds) << "\n";
    std::error_code ec;
    const auto size = std::filesystem::file_size(a.output, ec);
    o << "wrote    " << a.output << " (" << (ec ? std::string("?") : format_bytes(size)) << ")\n";
    detail(model_detail);
    return 0;
}

const CommandRegistration registration{Command{
    "extract", "Build a model of a volume and write a level-of-detail tetrahedral mesh", 20,
    [](CLI::App& sub) -> std::function<int()> {
        auto a = std::make_shared<ExtractArgs>();
        sub.add_option("input", a->input, "Input volume file")->required();
        sub.add_option("output", a->output, "Output mesh: " + mesh_format_summary())->required();
        add_volume_flags(sub, a->volume);

        const std::string lod =
            "Level of detail (E: absolute like 0.5, percent of the value "
            "range like 1%, inf, or negative = full resolution)";
        add_lod_flags(sub, a->lod, lod, "Largest error allowed (inside the region if any)",
                      "Full-resolution reference mesh");

        const std::string model = "Model and output";
        sub.add_option("--model", a->model,
                       "Multiresolution model: ht (Hierarchy of Tetrahedra) or mt "
                       "(Multi-Tessellation). Default: ht, or the MT of a .tlod holding only an MT")
            ->group(model)
            ->check(CLI::IsMember({"ht", "mt"}));
        sub.add_flag("--pad", a->pad,
                     "Embed the volume in the enclosing (2^k+1)^3 cube (mesh covers it)")
            ->group(model);
        sub.add_option("--format", a->format, "Mesh format (default: from the extension)")
            ->group(model)
            ->check(CLI::IsMember(mesh_format_names()));
        sub.add_flag("--no-compress", a->no_compress, "Store .vtu arrays uncompressed")
            ->group(model);
        sub.footer(
            "Examples:\n"
            "  tetlod extract bucky_32x32x32_uint8.raw bucky.vtu --error 1%\n"
            "  tetlod extract head.raw head.vtu --dims 256,256,99 --dtype u16 \\\n"
            "      --error 0 --box 64,64,20,192,192,80 --error-out 5%\n"
            "  tetlod extract ml_65x65x65_uint8.raw iso.vtk --isovalue 128 --error 0.5\n"
            "  tetlod extract ml_65x65x65_uint8.raw ml_mt.vtu --model mt --error 1%\n");
        return [a] { return run_extract(*a); };
    }}};

}  // namespace

}  // namespace tetlod::cli
