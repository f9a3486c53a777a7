// tetlod decode: a .tlod container -> the original volume in any volume format,
// bit-exact; or, with --error/--full (and the region flags of extract), the
// volume as a level-of-detail mesh represents it: every grid point interpolated
// in its tet (analysis/mesh_resample.hpp), with the deviation from the original.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>
#include <optional>
#include <ostream>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"
#include "model_choice.hpp"

namespace tetlod::cli {

namespace {

struct DecodeArgs {
    std::string input, output, format, model;  // empty: not given
    LodFlags lod;
    VolumeFlags volume;
};

/// Planes passed through, drawing the progress bar as they are read.
class ProgressPlanes final : public VolumePlanes {
public:
    ProgressPlanes(std::unique_ptr<VolumePlanes> inner, ProgressBar& bar) : inner_(std::move(inner)), bar_(bar) {}
    const Volume& header() const override { return inner_->header(); }
    void read(int64_t z0, int64_t count, std::byte* dst) override {
        inner_->read(z0, count, dst);
        bar_.update(uint64_t(z0 + count), uint64_t(header().dims.z));
    }

private:
    std::unique_ptr<VolumePlanes> inner_;
    ProgressBar& bar_;
};

void print_written(const std::string& output, const VolumeLocation& where, const Volume& v,
                   double seconds) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(where.file, ec);
    out() << "wrote    " << output << ": " << format_dims(v.dims) << " " << value_type_name(v.type)
          << ", " << (ec ? std::string("?") : format_bytes(size)) << " in " << format_seconds(seconds)
          << "\n";
    if (where.format->name == "raw")
        out() << "read it back with: --dims " << format_dims(v.dims, ',') << " --dtype "
              << value_type_name(v.type) << " --spacing " << format_number(v.spacing[0]) << ','
              << format_number(v.spacing[1]) << ',' << format_number(v.spacing[2]) << " --origin "
              << format_number(v.origin[0]) << ',' << format_number(v.origin[1]) << ','
              << format_number(v.origin[2]) << "\n";
}

// Metadata the output format cannot hold is written without, never refused,
// and said so on stderr (the key names, so nothing is lost silently) unless -q.
void warn_metadata_lost(const Volume& v, const std::string& output, const std::string& format) {
    if (verbosity() < 0) return;  // -q: errors only
    const auto lost = metadata_keys_lost(v, output, format);
    if (lost.empty()) return;
    std::string keys;
    for (const auto& k : lost) keys += (keys.empty() ? "'" : ", '") + k + "'";
    std::cerr << "tetlod: warning: '" << output << "' cannot hold metadata " << keys
              << "; written without " << (lost.size() == 1 ? "it" : "them") << "\n";
}

/// A lossy container (format 3.1) decodes to its stored field, not the
/// original: said on stderr (unless -q), with the bound it honours.
void note_if_lossy(const std::string& input, bool lod) {
    if (verbosity() < 0) return;
    auto info = inspect_container(input);
    if (!info || !(info->max_error > 0)) return;
    const std::string e = format_max_error(info->max_error);
    std::cerr << "tetlod: lossy container: every sample within " << e << " of the original"
              << (lod ? " (the deviation below is measured against the stored field; against the original "
                        "add at most " + e + ")"
                      : "")
              << "\n";
}

int run_decode(const DecodeArgs& a) {
    const bool lod = a.lod.full || !a.lod.error.empty() || a.lod.has_region() ||
                     !a.lod.error_out.empty();
    if (lod && !a.lod.full && a.lod.error.empty())
        throw Error(ErrorCode::InvalidArgument,
                    "--box, --isovalue and --error-out need --error E (or --full)");
    a.lod.validate(/*need_error=*/false);
    if (!a.model.empty() && !lod)
        throw Error(ErrorCode::InvalidArgument,
                    "--model applies to level-of-detail decoding: give --error E or --full");
    // Check the output name before any work: unknown extension or format not built.
    const VolumeLocation where = locate_volume(a.output, a.format);
    if (!where.format->built)
        throw Error(ErrorCode::NotBuilt,
                    "'" + a.output + "': this build of tetlod cannot write that format");
    // A .tlod name that is missing or not a container gets the container reader's message.
    const bool container = is_container_path(a.input);
    Stopwatch clock;

    if (!lod) {  // the original volume, bit-exact
        if (container) {
            note_if_lossy(a.input, false);
            // Plane by plane: a container decodes a row of bricks at a time and
            // every built-in output format takes it plane by plane.
            ProgressBar bar("decoding", "planes");
            ProgressPlanes planes(open_container_planes(a.input).take(), bar);
            write_volume(planes, a.output, a.format);
            warn_metadata_lost(planes.header(), a.output, a.format);
            print_written(a.output, where, planes.header(), clock.seconds());
            return 0;
        }
        const Volume v = load_volume(a.input, a.volume.options());
        write_volume(v, a.output, a.format);
        warn_metadata_lost(v, a.output, a.format);
        print_written(a.output, where, v, clock.seconds());
        return 0;
    }

    const bool mt = resolve_model(a.model, a.input) == ModelKind::Mt;
    const auto error_in = a.lod.error_in();
    const auto error_out = a.lod.error_out_threshold();
    LodQuery query = a.lod.region_query(nullptr);

    // The original volume and the model (a container's stored model; a volume's
    // built below, after the box is checked against its dims).
    const ModelKind kind = mt ? ModelKind::Mt : ModelKind::Ht;
    std::optional<LodModel> model;
    Volume original;
    if (container) {  // the field decoded once, for both
        note_if_lossy(a.input, true);
        StoredModel stored = open_stored_model(a.input, kind).take();
        model = std::move(stored.model);
        original = std::move(stored.volume);
    } else {
        original = load_volume(a.input, a.volume.options());
    }
    const double load_seconds = clock.seconds();
    const Dims dims = original.dims;
    a.lod.check_box_meets(query, dims);
    Stopwatch build_clock;
    if (!container) model = build_model(kind, Volume(original));
    const double build_seconds = container ? 0.0 : build_clock.seconds();
    const auto range = model->range;
    query.error_in = error_in.resolve(range);
    query.error_out = error_out.resolve(range);

    Stopwatch extract_clock;
    const TetMesh mesh = model->extract(query);
    const double extract_seconds = extract_clock.seconds();
    model.reset();

    Stopwatch resample_clock;
    const LodVolume lod_result = lod_volume(mesh, original);
    const Volume& lodv = lod_result.volume;
    const LodDeviation& dev = lod_result.deviation;
    const double resample_seconds = resample_clock.seconds();

    Stopwatch write_clock;
    write_volume(lodv, a.output, a.format);
    warn_metadata_lost(lodv, a.output, a.format);
    const double write_seconds = write_clock.seconds();

    auto& o = out();
    o << "input    " << with_stdin_named(a.input) << ": " << format_dims(dims) << " " << value_type_name(original.type)
      << ", values " << format_number(range[0]) << ".." << format_number(range[1])
      << (container ? " (.tlod)" : "") << "\n";
    o << "query    " << (mt ? "MT" : "HT") << ", " << a.lod.describe(query, range) << "\n";
    o << "mesh     " << mesh.tet_count() << " tets, " << mesh.vertex_count()
      << " vertices, largest error " << format_error(dev.mesh_error, range) << "\n";
    o << "deviation max " << format_error(dev.max, range) << ", mean " << format_number(dev.mean) << " over "
      << dev.grid_points << " grid points\n";
    o << "time     " << (container ? "load " + format_seconds(load_seconds)
                                   : "read " + format_seconds(load_seconds) + ", build " +
                                         format_seconds(build_seconds))
      << ", extract " << format_seconds(extract_seconds) << ", resample "
      << format_seconds(resample_seconds) << ", write " << format_seconds(write_seconds) << "\n";
    print_written(a.output, where, lodv, clock.seconds());
    return 0;
}

const CommandRegistration decode_registration{Command{
    "decode", "Decode a .tlod container to a volume: the original (bit-exact) or a LOD of it", 23,
    [](CLI::App& sub) -> std::function<int()> {
        auto a = std::make_shared<DecodeArgs>();
        sub.add_option("input", a->input, "Input .tlod file (or any volume file, for --error)")
            ->required();
        sub.add_option("output", a->output,
                       "Output volume: " + volume_format_summary())
            ->required();
        sub.add_option("--format", a->format, "Output format (default: from the extension)")
            ->check(CLI::IsMember(volume_format_names()));
        add_volume_flags(sub, a->volume);

        const std::string lod =
            "Level of detail (optional; E: absolute like 0.5, percent of the value range like 1%, "
            "inf, or negative = full resolution)";
        add_lod_flags(sub, a->lod, lod,
                      "Decode the LOD mesh at this error (inside the region if any)",
                      "Decode the full-resolution mesh (equals the original)");
        sub.add_option("--model", a->model, "Model for --error: ht (default) or mt (default for a .tlod holding only an MT)")
            ->group(lod)
            ->check(CLI::IsMember({"ht", "mt"}));
        sub.footer(
            "Without --error/--full the original volume is written bit-exact: same value type,\n"
            "spacing, origin, field name, units and user metadata (convert --meta k=v). A lossy\n"
            "container (convert --max-error E) gives its stored field, every sample within E of\n"
            "the original, and says so on stderr.\n"
            "\n"
            "With --error E the output is the volume the LOD mesh at error E represents: every\n"
            "grid point is linearly interpolated in the tet containing it, from exact integer\n"
            "barycentric numerators. Integer types: the rational value rounded to nearest (ties\n"
            "up) and clamped to the type's range, so the deviation is at most E rounded to\n"
            "nearest; float types: computed in double, then cast. Prints the max and mean\n"
            "absolute deviation from the original over all grid points. A plain volume input\n"
            "builds the model on the fly (--model ht|mt).\n"
            "\n"
            "Examples:\n"
            "  tetlod decode neghip.tlod neghip.nrrd\n"
            "  tetlod decode neghip.tlod neghip_64x64x64_uint8.raw\n"
            "  tetlod decode neghip.tlod lod.h5:/volume --error 2%\n"
            "  tetlod decode ct.nhdr ct_lod.nrrd --error 1% --model mt\n");
        return [a] { return run_decode(*a); };
    }}};

}  // namespace

}  // namespace tetlod::cli
