// tetlod convert: a volume -> a .tlod container holding its HT (field stored
// losslessly, per-diamond error bounds), its MT, or both (--model), with
// provenance and user metadata.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <ostream>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"

namespace tetlod::cli {

namespace {

struct ConvertArgs {
    std::string input, output;
    VolumeFlags volume;
    bool pad = false;
    std::vector<std::string> meta;
    int level = 19;
    bool level_given = false;
    int brick_log2 = 0;  // automatic (auto_brick_log2)
    int error_bits = 4;
    int mt_error_bits = 7;
    double max_shape_ratio = kDefaultMtMaxShapeRatio;
    std::string model = "ht";
    std::string max_error;  // empty: lossless
    std::string memory;  // empty: default_memory_budget()
    bool in_memory = false;
    std::string table = "compact";
    bool fast_decode = false;
};

int run_convert(const ConvertArgs& a) {
    Stopwatch sw;
    const bool with_ht = a.model == "ht" || a.model == "ht,mt" || a.model == "mt,ht";
    const bool with_mt = a.model == "mt" || a.model == "ht,mt" || a.model == "mt,ht";
    if (!with_ht && !with_mt)
        throw Error(ErrorCode::InvalidArgument, "--model '" + a.model + "': expected ht, mt or ht,mt");
    // --meta is checked before the (possibly long) read.
    for (const std::string& kv : a.meta) {
        const auto eq = kv.find('=');
        if (eq == std::string::npos || eq == 0)
            throw Error(ErrorCode::InvalidArgument, "--meta '" + kv + "': expected key=value");
        // Metadata is text for every reader (JSON, HDF5 UTF-8 attributes): refuse
        // bytes that are not UTF-8 (a Latin-1 shell, a mistyped escape).
        if (const std::size_t bad = first_invalid_utf8(kv); bad != kv.size())
            throw Error(ErrorCode::InvalidArgument,
                        "--meta: the " + std::string(bad < eq ? "key" : "value") + " of entry " +
                            std::to_string(&kv - a.meta.data() + 1) + " is not valid UTF-8 (byte " +
                            std::to_string(bad) + " of the argument); give UTF-8 text");
    }
    // --max-error is parsed like --error; a percentage waits for the value range.
    std::optional<ErrorThreshold> max_error;
    if (!a.max_error.empty()) {
        max_error = parse_error_threshold(a.max_error, "--max-error");
        if (!(max_error->value >= 0) || !std::isfinite(max_error->value))
            throw Error(ErrorCode::InvalidArgument,
                        "--max-error '" + a.max_error + "': expected a finite bound >= 0 (0: lossless)");
        if (max_error->value > 0 && with_mt && !with_ht)
            throw Error(ErrorCode::InvalidArgument,
                        "--max-error: a lossy field is stored in the HT; use --model ht or ht,mt "
                        "(an MT alone stores its field losslessly)");
    }
    const std::size_t memory = a.memory.empty() ? default_memory_budget() : parse_byte_size(a.memory, "--memory");
    auto add_meta = [&](std::map<std::string, std::string>& md) {
        for (const std::string& kv : a.meta) {
            const auto eq = kv.find('=');
            md[kv.substr(0, eq)] = kv.substr(eq + 1);
        }
    };
    // The HT alone is converted plane by plane, in bounded memory, from a
    // format that reads planes (raw, NRRD, MetaImage, HDF5, OpenVDB); the
    // rest (formats added without open_planes) reads the volume whole.
    std::unique_ptr<VolumePlanes> planes;
    // Lossy too: the library reads the volume whole when that fits the budget
    // (the best field is chosen in the coder's order), else streams two candidates.
    if (with_ht && !with_mt && !a.in_memory) planes = open_volume_planes(a.input, a.volume.options());
    std::optional<Volume> whole;
    if (planes) {
        Volume h = planes->header();
        add_meta(h.metadata);
        planes = with_header(std::move(planes), std::move(h));
        detail("converting " + with_stdin_named(a.input) + " plane by plane in at most " + format_bytes(memory));
    } else {
        if (!a.memory.empty() && !a.in_memory)
            detail("note: " + with_stdin_named(a.input) + " is read whole (" +
                   std::string(with_mt ? "the MT is built in memory" : "its format is not read plane by plane") +
                   "); --memory does not bound this conversion");
        whole = load_volume(a.input, a.volume.options());
        add_meta(whole->metadata);
        detail("read " + with_stdin_named(a.input) + ": " + format_dims(whole->dims) + " " + value_type_name(whole->type) + " in " +
               format_seconds(sw.seconds()));
    }
    const Volume& header = planes ? planes->header() : *whole;

    const bool bar = show_progress();
    std::optional<ProgressBar> encoding, building;
    const double n = double(header.dims.count());
    const std::size_t value_bytes = value_size(header.type);
    ContainerWriteOptions wo;
    wo.memory_bytes = memory;
    wo.ht = with_ht;
    wo.mt = with_mt;
    wo.pad = a.pad;
    wo.zstd_level = a.level;
    // An explicit --level is the level of every frame, the MT's large streams too.
    if (a.level_given) wo.mt_large_stream_zstd_level = a.level;
    wo.brick_log2 = a.brick_log2;
    wo.error_bits = a.error_bits;
    wo.mt_error_bits = a.mt_error_bits;
    wo.mt_max_shape_ratio = a.max_shape_ratio;
    wo.table = a.table == "full" ? tlod::TableLayout::full : tlod::TableLayout::compact;
    wo.fast_decode = a.fast_decode;
    if (max_error && max_error->value > 0) {
        // Percent of the original's range: one more read when streaming.
        const std::array<double, 2> range =
            !max_error->percent ? std::array<double, 2>{0, 0}
            : planes            ? planes_value_range(*planes)
                                : planes_value_range(*planes_of(*whole));
        wo.max_error = max_error->resolve(range);
        detail("--max-error " + a.max_error + " = " + format_max_error(wo.max_error) +
               " in field units (integers honour its integer part)");
        if (planes)
            detail(lossy_reads_whole(planes->header(), memory)
                       ? "lossy: converted in memory (within " + format_bytes(memory) + "), the best of three fields kept"
                       : "lossy: more than " + format_bytes(memory) +
                             " in memory: the lossless and lattice fields streamed, the smaller kept");
    }
    wo.source_path = a.input;
    wo.converter = "tetlod convert";
    wo.progress = [&](const std::string& stage, std::size_t done, std::size_t total) {
        if (stage == "build MT") {
            // Work units weighted by pass (MtBuildOptions::progress): shown as a percentage.
            if (!building) building.emplace("building the MT", "%");
            building->update(total ? done * 100 / total : 0, 100);
        } else if (stage == "built MT") {
            building.reset();  // erases the bar
            detail("built the MT in " + format_seconds(sw.seconds()));
        } else if (stage == "build HT") {
            if (bar) std::fprintf(stderr, "building the HT (errors of every diamond)...\r");
        } else if (stage == "built HT") {
            detail("built the HT in " + format_seconds(sw.seconds()));
        } else if (stage == "encode HT") {
            if (!encoding) encoding.emplace("encoding", planes ? "planes" : "chunks");
            encoding->update(done, total);
        } else if (stage == "scan HT") {
            if (!encoding) encoding.emplace("scanning", "planes");
            encoding->update(done, total);
            if (done == total) {
                encoding.reset();
                detail("scanned " + with_stdin_named(a.input) + " (range, coarse lattice) in " + format_seconds(sw.seconds()));
            }
        } else if (stage == "encoded HT") {
            encoding.reset();  // erases the bar
        } else if (stage == "encode MT") {
            // One step without a count (zstd of the MT's streams, in parallel).
            if (bar) std::fprintf(stderr, "encoding the MT (zstd of its streams)...\r");
        } else if (stage == "encoded MT") {
            if (bar) std::fprintf(stderr, "\r%*s\r", 72, "");
            detail("encoded the MT in " + format_seconds(sw.seconds()));
        }
    };
    const ContainerWriteSummary written =
        planes ? write_container(*planes, a.output, wo) : write_container(std::move(*whole), a.output, wo);
    std::string summary;
    if (written.ht_k >= 0)
        summary += ", HT k = " + std::to_string(written.ht_k) + ", levels 0.." +
                   std::to_string(written.ht_max_level);
    if (with_mt)
        summary += ", MT " + std::to_string(written.mt_updates) + " updates on " +
                   std::to_string(written.mt_base_tets) + " base tets";

    std::error_code size_error;  // "-" (standard output) has no size
    const uint64_t size = std::filesystem::file_size(a.output, size_error);
    if (written.max_error > 0) summary += ", lossy: every sample within " + format_max_error(written.max_error);
    else if (wo.max_error > 0)
        summary += ", stored losslessly (smaller than any field within --max-error, or an integer bound below 1)";
    out() << "wrote " << a.output << ": " << format_bytes(size) << ", "
          << format_number(double(size) / n) << " bytes per grid point (raw "
          << format_number(double(value_bytes)) << ")" << summary << ", " << format_seconds(sw.seconds())
          << "\n";
    return 0;
}

const CommandRegistration convert_registration{Command{
    "convert", "Convert a volume into a .tlod container (HT and/or MT, lossless field)", 20,
    [](CLI::App& sub) -> std::function<int()> {
        auto a = std::make_shared<ConvertArgs>();
        sub.add_option("input", a->input, "Input volume")->required();
        sub.add_option("output", a->output, "Output .tlod file (written atomically)")->required();
        add_volume_flags(sub, a->volume);
        auto* g = "Container";
        sub.add_flag("--pad", a->pad,
                     "Embed the data in the enclosing (2^k+1)^3 cube (coarser meshes; they cover "
                     "the padded cube)")
            ->group(g);
        sub.add_option("--model", a->model, "Models to store: ht, mt or ht,mt (the MT shares the HT's field)")
            ->capture_default_str()
            ->group(g);
        sub.add_option("--memory", a->memory,
                       "Memory the HT conversion may use, e.g. 512M or 4G (default: a quarter of RAM); "
                       "raw input is then read plane by plane, whatever its size")
            ->group(g);
        sub.add_flag("--in-memory", a->in_memory,
                     "Read the whole volume first and build the HT in memory (faster when it fits)")
            ->group(g);
        sub.add_option("--max-error", a->max_error,
                       "Lossy archival: store a field whose every sample is within E of the original "
                       "(absolute, or P% of the value range); error bounds, so extract --error, stay "
                       "stated against the original. 0: lossless (default). HT only")
            ->group(g);
        sub.add_option("--meta", a->meta, "User metadata key=value (repeatable)")->group(g);
        sub.add_option("--table", a->table,
                       "Section table layout: compact (format 3.2, smallest) or full (48 bytes a section, "
                       "and no range-2d chunks of format 3.6: a 3.0/3.1 file that older tetlod readers open; "
                       "--fast-decode is then refused)")
            ->capture_default_str()
            ->check(CLI::IsMember({"compact", "full"}))
            ->group(g);
        sub.add_flag("--fast-decode", a->fast_decode,
                     "Code the HT's field for decoding speed: static-table rANS chunks (format 3.7), several "
                     "times faster to decode, for a larger file (docs/archival.md, \"Fast decoding\")")
            ->group(g);
        sub.add_option("--level", a->level,
                       "zstd level of every frame, the HT chunks' fallback frames included (below 19: faster, "
                       "larger; docs/archival.md). Default: 19, but 12 for MT streams above 1 MiB (docs/mt.md §5)")
            ->capture_default_str()
            ->check(CLI::Range(1, 22))
            ->each([a](const std::string&) { a->level_given = true; })
            ->group(g);
        sub.add_option("--brick-log2", a->brick_log2,
                       "Bricks of cycle t span 2^(t+1+N) grid steps (smaller: finer box reads, larger: smaller "
                       "files). 0: 5 when no axis has more than 129 samples, else 4")
            ->capture_default_str()
            ->check(CLI::Range(0, 16))
            ->group(g);
        sub.add_option("--error-bits", a->error_bits,
                       "HT: mantissa bits of stored error bounds (bound <= error * (1 + 2^-N))")
            ->capture_default_str()
            ->check(CLI::Range(0, 7))
            ->group(g);
        sub.add_option("--mt-error-bits", a->mt_error_bits,
                       "MT: mantissa bits of stored error bounds (bound <= error * (1 + 2^-N)); "
                       "fewer store less for a few % more tets per LOD")
            ->capture_default_str()
            ->check(CLI::Range(0, 7))
            ->group(g);
        sub.add_option("--max-shape-ratio", a->max_shape_ratio,
                       "MT: refuse collapses creating tets whose circumradius / shortest edge exceeds R "
                       "(no slivers, a few % more tets); 0: no cap")
            ->capture_default_str()
            ->check(CLI::NonNegativeNumber)
            ->group(g);
        sub.footer("Examples:\n"
                   "  tetlod convert neghip_64x64x64_uint8.raw neghip.tlod\n"
                   "  tetlod convert neghip_64x64x64_uint8.raw neghip.tlod --model ht,mt\n"
                   "  tetlod convert neghip_64x64x64_uint8.raw neghip_lossy.tlod --max-error 0.5%\n"
                   "  tetlod convert neghip_64x64x64_uint8.raw neghip_old.tlod --table full\n"
                   "  tetlod convert ct.raw ct.tlod --dims 512,512,300 --dtype i16 --meta patient=anon");
        return [a] { return run_convert(*a); };
    }}};

}  // namespace

}  // namespace tetlod::cli
