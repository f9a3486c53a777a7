// tetlod extract: builds the multiresolution model of a volume and writes one
// level-of-detail mesh: uniform (--error), region-driven (--box, --isovalue with
// --error inside and --error-out elsewhere) or the full-resolution reference.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>
#include <ostream>
#include <span>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"
#include "model_choice.hpp"

namespace tetlod::cli {

namespace {

struct ExtractArgs {
    std::string input, output, model, format;  // empty: not given
    LodFlags lod;
    bool pad = false, no_compress = false;
    std::string compress = "zlib";
    double max_shape_ratio = kDefaultMtMaxShapeRatio;
    int compress_level = 0;
    uint64_t cache_mb = 1024;
    VolumeFlags volume;
};

MeshWriteOptions mesh_write_options(const ExtractArgs& a) {
    MeshWriteOptions o;
    o.compression = a.no_compress ? MeshCompression::None : *parse_mesh_compression(a.compress);
    o.compression_level = a.compress_level;
    return o;
}

/// The writer behind a progress bar over the tets written (on a terminal,
/// without -q or --no-progress).
class ProgressSink final : public TetMeshSink {
public:
    /// `before`: the bar of the refinement, erased when writing starts.
    explicit ProgressSink(TetMeshSink& to, std::optional<ProgressBar>* before = nullptr) : to_(to), before_(before) {}
    void begin(const TetMesh& v, uint64_t n) override {
        if (before_) before_->reset();
        total_ = n;
        bar_.emplace("writing", "tets");
        to_.begin(v, n);
    }
    void add(std::span<const std::array<uint32_t, 4>> t, std::span<const uint8_t> l,
             std::span<const float> e) override {
        to_.add(t, l, e);
        done_ += t.size();
        bar_->update(done_, total_);
    }
    void finish() override {
        to_.finish();
        bar_.reset();
    }

private:
    TetMeshSink& to_;
    std::optional<ProgressBar>* before_;
    std::optional<ProgressBar> bar_;
    uint64_t total_ = 0, done_ = 0;
};

ContainerExtractOptions extract_options(const ExtractArgs& a) {
    ContainerExtractOptions o;
    o.cache_bytes = std::size_t(a.cache_mb) << 20;
    return o;
}

/// A lossy container's finest mesh honours its field.max_error E, no less: a
/// threshold below E gets that mesh (spec §5.1), which the user should know.
void warn_if_below_field_error(const std::string& input, const ContainerExtract& x) {
    const double E = x.field_max_error;
    if (!(E > 0) || verbosity() < 0) return;
    if (x.query.full) return;  // asked for the finest mesh, not for a bound
    const bool inside = x.query.error_in < E;
    const bool outside = x.query.has_region() && x.query.error_out < E;
    if (!inside && !outside) return;
    std::cerr << "tetlod: warning: '" << input << "' is lossy (every sample within " << format_max_error(E)
              << " of the original): no mesh honours an error below that; the finest mesh was written where --error"
              << (outside && !inside ? "-out" : "") << " asks for less\n";
}

// A container: the HT read lazily (only the chunks the query examines), or its MT.
int run_extract_container(const ExtractArgs& a, ModelKind model) {
    const auto error_in = a.lod.error_in();
    const auto error_out = a.lod.error_out_threshold();
    // The mesh streams into the writer (memory does not grow with the tets).
    const auto sink = open_mesh_stream(a.output, a.format, mesh_write_options(a));
    // Refining: the chunks read so far, of all the file holds (a coarse or
    // local query reads few of them).
    std::optional<ProgressBar> reading;
    reading.emplace("refining", "chunks read");
    ContainerExtractOptions options = extract_options(a);
    options.progress = [&](uint64_t done, uint64_t total) {
        if (reading) reading->update(done, total);
    };
    ProgressSink shown(*sink, &reading);
    const ContainerExtract x =
        extract_from_container_to(a.input, model, a.lod.region_query(nullptr), shown,
                                  [&](LodQuery& q, const std::array<double, 2>& range) {
                                      q.error_in = error_in.resolve(range);
                                      q.error_out = error_out.resolve(range);
                                  },
                                  options)
            .take();
    auto& o = out();
    if (model == ModelKind::Mt) {
        o << "input    " << with_stdin_named(a.input) << ": " << format_dims(x.dims) << " " << value_type_name(x.type)
          << " (.tlod, MT: " << x.mt_updates << " vertex splits, field "
          << (x.mt_field_from_ht ? "from the HT" : "in the MT") << ")\n";
        o << "mesh     " << x.tet_count << " tets, " << x.vertex_count << " vertices, largest error "
          << format_error(x.max_error, x.range) << (x.field_max_error > 0 ? " against the original (lossy field)" : "")
          << ", " << format_seconds(x.seconds) << "\n";
        warn_if_below_field_error(a.input, x);
    } else {
        o << "input    " << with_stdin_named(a.input) << ": " << format_dims(x.dims) << " " << value_type_name(x.type)
          << " (.tlod, lazy)\n";
        o << "mesh     " << x.tet_count << " tets, " << x.vertex_count
          << " vertices, largest error " << format_error(x.max_error, x.range)
          << (x.field_max_error > 0 ? " against the original (lossy field)" : "") << "\n";
        warn_if_below_field_error(a.input, x);
        // The file's bytes touched, each once; sections read again (the metadata
        // by the opener and the extractor, chunks evicted and needed again) apart.
        o << "read     " << format_bytes(x.distinct_bytes_read) << " of " << format_bytes(x.file_size);
        if (x.bytes_read > x.distinct_bytes_read) o << " (" << format_bytes(x.bytes_read) << " with re-reads)";
        o << ", " << x.chunks_decoded << " of " << x.chunks_total << " chunks";
        if (x.chunk_decodes > x.chunks_decoded) o << " (" << x.chunk_decodes << " decodings: raise --cache-mb)";
        o << ", cache " << format_bytes(x.cache_peak_bytes) << ", " << format_seconds(x.seconds) << "\n";
        detail("time     refine " + format_seconds(x.refine_seconds) + ", emit + write " +
               format_seconds(x.emit_seconds));
    }
    o << "wrote    " << a.output << "\n";
    return 0;
}

int run_extract(const ExtractArgs& a) {
    const bool mt = resolve_model(a.model, a.input) == ModelKind::Mt;
    if (mt && a.pad)
        throw Error(ErrorCode::InvalidArgument,
                    "--pad applies to the HT only (the MT always covers the data's bounding box): "
                    "drop --pad or use --model ht");
    a.lod.validate(/*need_error=*/true);
    const auto error_in = a.lod.error_in();
    const auto error_out = a.lod.error_out_threshold();

    if (is_container_path(a.input)) return run_extract_container(a, mt ? ModelKind::Mt : ModelKind::Ht);
    Volume volume = load_volume(a.input, a.volume.options());
    const Dims dims = volume.dims;
    const std::string type_name = value_type_name(volume.type);
    LodQuery query = a.lod.region_query(&dims);

    ModelBuildOptions build_options;
    build_options.pad = a.pad;
    build_options.mt_max_shape_ratio = a.max_shape_ratio;
    std::optional<ProgressBar> building;  // MT: weighted work units, shown as a percentage
    build_options.mt_progress = [&](uint64_t done, uint64_t total) {
        if (!building) building.emplace("building the MT", "%");
        building->update(total ? done * 100 / total : 0, 100);
    };
    const LodModel model = build_model(mt ? ModelKind::Mt : ModelKind::Ht, std::move(volume), build_options);
    building.reset();  // erases the bar
    const double build_seconds = model.build_seconds;
    const std::array<double, 2> range = model.range;
    query.error_in = error_in.resolve(range);
    query.error_out = error_out.resolve(range);
    LodExtractStats stats;
    // The mesh streams into the writer: extraction and writing are one step.
    Stopwatch extract_clock;
    const auto sink = open_mesh_stream(a.output, a.format, mesh_write_options(a));
    ProgressSink shown(*sink);
    TetMeshCounter counted(shown);
    model.extract_to(query, counted, &stats);
    const double extract_seconds = extract_clock.seconds();
    const double max_error = stats.max_error;
    const std::string model_detail =
        mt ? "model: MT, " + std::to_string(model.updates) + " vertex splits, " +
                 std::to_string(model.mt_base_tets) + " base tets; " + std::to_string(stats.splits) +
                 " splits applied (" + std::to_string(stats.forced_splits) + " forced), " +
                 std::to_string(stats.visited_tets) + " tets visited"
           : "model: HT, cube side 2^" + std::to_string(model.ht_k) + (model.ht_padded ? " (padded)" : "") +
                 ", " + std::to_string(stats.splits) + " diamonds split, " +
                 std::to_string(stats.visited_tets) + " tets visited";

    auto& o = out();
    o << "input    " << with_stdin_named(a.input) << ": " << format_dims(dims) << " " << type_name << ", values "
      << format_number(range[0]) << ".." << format_number(range[1]) << "\n";
    o << "query    " << a.lod.describe(query, range) << "\n";
    o << "mesh     " << counted.tets << " tets, " << counted.vertices
      << " vertices, largest error " << format_error(max_error, range) << "\n";
    o << "time     build " << format_seconds(build_seconds) << ", extract + write "
      << format_seconds(extract_seconds) << "\n";
    std::error_code ec;
    const auto size = std::filesystem::file_size(a.output, ec);
    o << "wrote    " << a.output << " (" << (ec ? std::string("?") : format_bytes(size)) << ")\n";
    detail(model_detail);
    return 0;
}

const CommandRegistration extract_registration{Command{
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
        sub.add_option("--max-shape-ratio", a->max_shape_ratio,
                       "MT built from a volume: refuse collapses creating tets whose circumradius / shortest "
                       "edge exceeds R; 0: no cap")
            ->capture_default_str()
            ->group(model)
            ->check(CLI::NonNegativeNumber);
        sub.add_option("--compress", a->compress,
                       "Block compressor of .vtu arrays: zlib (read everywhere), lz4 (fastest; VTK/ParaView only), "
                       "lzma (smallest) or none")
            ->group(model)
            ->capture_default_str()
            ->check(CLI::IsMember({"lz4", "zlib", "lzma", "none"}));
        sub.add_option("--compress-level", a->compress_level, "Compressor level 1 (fastest) .. 9 (smallest); 0: its default")
            ->group(model)
            ->check(CLI::Range(0, 9));
        sub.add_flag("--no-compress", a->no_compress, "Store .vtu arrays uncompressed (= --compress none)")
            ->group(model);
        sub.add_option("--cache-mb", a->cache_mb,
                       "From a .tlod (HT): memory for decoded chunks, in MiB. A query examining more "
                       "decodes chunks again (same mesh, slower)")
            ->group(model)
            ->capture_default_str()
            ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 30));
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
