#pragma once
// Helpers shared by the subcommands: verbosity, the volume input flags, loading
// a volume, and parsing of thresholds, boxes and vectors. Every parse failure is
// a tetlod::Error(InvalidArgument) naming the flag and the bad text.
#include <array>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "cli_parse.hpp"
#include "tetlod/tetlod.hpp"

namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace tetlod::cli {

/// -1 quiet, 0 normal, 1+ verbose. Set once by main after parsing.
int verbosity();
void set_verbosity(int level);
/// --progress / --no-progress as given (nullopt: neither, the default applies).
void set_progress(std::optional<bool> forced);
/// Whether long steps draw progress on stderr: forced by --progress/--no-progress,
/// else when stderr is a terminal and not -q (zstd's convention).
bool show_progress();

/// A progress bar on stderr for one long step ("decoding [####    ] 12/40 chunks"),
/// drawn only when show_progress(), at most every 100 ms, erased when done.
class ProgressBar {
public:
    ProgressBar(std::string what, std::string unit);
    ~ProgressBar();
    void update(uint64_t done, uint64_t total);

private:
    std::string what_, unit_;
    bool on_;
    double last_ = -1;
    bool drawn_ = false;
};
/// Where results go: stdout, or a sink that drops everything under -q; stderr
/// when the command writes its output to standard output ("-").
std::ostream& out();
void set_results_to_stderr(bool yes);
/// Verbose detail (-v) to stderr.
void detail(const std::string& message);

/// Raw-volume and geometry flags as typed; converted after parsing so errors
/// name the flag.
struct VolumeFlags {
    std::string dims, dtype, endian = "little", spacing, origin, grid, axis_order;
    uint64_t header_bytes = 0;
    bool allow_external_data = false;
    VolumeReadOptions options() const;
};
/// Adds --dims --dtype --endian --header-bytes --spacing --origin (raw) and
/// --grid (OpenVDB) --axis-order (HDF5) to `sub`, in a "Volume input" group, each
/// validated while CLI11 parses (bad text: exit 2).
void add_volume_flags(CLI::App& sub, VolumeFlags& flags);

/// Reads a volume file (raw, .nrrd/.nhdr, .mhd/.mha, .vdb, FILE.h5:/dataset):
/// the single place the tools pick a reader for a path.
Volume load_volume(const std::string& path, const VolumeReadOptions& options);

/// Parsers; `flag` names the option in error messages (empty inside CLI11
/// checks, which name the option themselves).
Dims parse_dims(const std::string& text, const std::string& flag);
Vec3 parse_vec3(const std::string& text, const std::string& flag);
ValueType parse_dtype(const std::string& text, const std::string& flag);
/// Inclusive index box x0,y0,z0,x1,y1,z1 with x0 <= x1, y0 <= y1, z0 <= z1.
std::array<int64_t, 6> parse_box(const std::string& text, const std::string& flag);
double parse_number(const std::string& text, const std::string& flag);
/// "512M", "2G", "1.5GiB", "1073741824" -> bytes (K/M/G/T are powers of 1024).
std::size_t parse_byte_size(const std::string& text, const std::string& flag);

/// --error-style bound (cli_parse.hpp's ErrorThreshold).
ErrorThreshold parse_error_threshold(const std::string& text, const std::string& flag);

/// Texts of the registered query-region flags given, by region name.
using RegionFlags = std::map<std::string, std::string>;

/// --<name> TEXT for every registered query region, into `regions` (group `group`).
void add_region_flags(CLI::App& sub, RegionFlags& regions, const std::string& group);
/// Puts the regions given into `query` (parsed; InvalidArgument naming the flag).
void apply_region_flags(const RegionFlags& regions, LodQuery& query);
/// "box B, 2 isovalue(s), sphere ..." for the parts of `query`'s region.
std::string describe_region(const LodQuery& query, const std::string& box_text);

/// The level-of-detail flags that extract and decode share, as typed: --error,
/// --error-out, --box, --isovalue, --full. Empty strings: not given.
struct LodFlags {
    std::string error, error_out, box;
    std::vector<std::string> isovalues;
    /// --<name> TEXT of the registered query regions (tetlod/models/query_region.hpp).
    RegionFlags regions;
    bool full = false;

    bool has_region() const { return !box.empty() || !isovalues.empty() || !regions.empty(); }
    /// Refuses contradictory or missing flags (--error-out without a region;
    /// neither --error nor --full when `need_error`).
    void validate(bool need_error) const;
    /// The thresholds as given (resolved against a value range later).
    ErrorThreshold error_in() const;
    ErrorThreshold error_out_threshold() const;
    /// The query's region and --full; `dims` (when given) must meet the box.
    LodQuery region_query(const Dims* dims) const;
    /// Refuses a box that misses the data (the query would silently be uniform).
    void check_box_meets(const LodQuery& q, const Dims& dims) const;
    /// "full resolution" or "error <= E in the region (box ..., N isovalue(s)), E2
    /// elsewhere", for the summary the commands print.
    std::string describe(const LodQuery& resolved, const std::array<double, 2>& range) const;
};

/// Adds --error --error-out --box --isovalue --full to `sub` in `group`, each
/// validated while CLI11 parses; `error_help` and `full_help` say what they mean
/// for the command.
void add_lod_flags(CLI::App& sub, LodFlags& flags, const std::string& group,
                   const std::string& error_help, const std::string& full_help);

/// Makes a CLI11 check from a parser that throws tetlod::Error, so bad text is a
/// parse error (exit 2) reported before any work starts. Call the parser with
/// an empty flag name: CLI11 prefixes the option's name to the message.
std::function<std::string(const std::string&)> check_with(
    std::function<void(const std::string&)> parse);

}  // namespace tetlod::cli
