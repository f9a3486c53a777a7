#include "cli_common.hpp"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <vector>

#include "byte_size.hpp"

namespace tetlod::cli {

namespace {

int g_verbosity = 0;
bool g_results_to_stderr = false;

// An empty flag leaves the name out: CLI11 prefixes its own when a check fails.
Error bad(const std::string& flag, const std::string& text, const std::string& why) {
    return Error(ErrorCode::InvalidArgument,
                 (flag.empty() ? "" : flag + " ") + "'" + text + "': " + why);
}

int64_t parse_int(const std::string& text, const std::string& flag, const std::string& whole) {
    const auto v = integer_from(text);
    if (!v) throw bad(flag, whole, "'" + text + "' is not an integer");
    return *v;
}

}  // namespace

int verbosity() { return g_verbosity; }
void set_verbosity(int level) { g_verbosity = level; }

namespace {
std::optional<bool> g_progress;
}  // namespace

void set_progress(std::optional<bool> forced) { g_progress = forced; }

bool show_progress() {
    if (g_progress) return *g_progress;
    return g_verbosity >= 0 && ::isatty(STDERR_FILENO);
}

ProgressBar::ProgressBar(std::string what, std::string unit)
    : what_(std::move(what)), unit_(std::move(unit)), on_(show_progress()) {}

ProgressBar::~ProgressBar() {
    if (drawn_) std::fprintf(stderr, "\r%*s\r", 72, "");
}

void ProgressBar::update(uint64_t done, uint64_t total) {
    if (!on_) return;
    const double now = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    if (done < total && now - last_ < 0.1) return;
    last_ = now;
    const int width = 30;
    const int fill = total ? int(width * std::min(done, total) / total) : width;
    std::fprintf(stderr, "\r%s [%.*s%*s] %llu/%llu %s", what_.c_str(), fill, "##############################",
                 width - fill, "", static_cast<unsigned long long>(done), static_cast<unsigned long long>(total),
                 unit_.c_str());
    std::fflush(stderr);
    drawn_ = true;
}

std::ostream& out() {
    static std::ostream null_stream(nullptr);  // no buffer: every write is dropped
    if (g_verbosity < 0) return null_stream;
    return g_results_to_stderr ? std::cerr : std::cout;
}

void set_results_to_stderr(bool yes) { g_results_to_stderr = yes; }

void detail(const std::string& message) {
    if (g_verbosity >= 1) std::cerr << message << "\n";
}

double parse_number(const std::string& text, const std::string& flag) {
    std::string why;
    const auto v = finite_number_from(text, why);
    if (!v) throw bad(flag, text, why);
    return *v;
}

std::size_t parse_byte_size(const std::string& text, const std::string& flag) {
    std::string why;
    const auto bytes = byte_size_from(text, why);
    if (!bytes) throw bad(flag, text, why);
    return *bytes;
}

Dims parse_dims(const std::string& text, const std::string& flag) {
    const auto parts = comma_fields(text);
    if (parts.size() != 3) throw bad(flag, text, "expected X,Y,Z");
    Dims d{parse_int(parts[0], flag, text), parse_int(parts[1], flag, text),
           parse_int(parts[2], flag, text)};
    for (int a = 0; a < 3; ++a)
        if (d[a] < 2) throw bad(flag, text, "every dimension must be at least 2");
    validate_dims(d, (flag.empty() ? "" : flag + " ") + "'" + text + "'");
    return d;
}

Vec3 parse_vec3(const std::string& text, const std::string& flag) {
    const auto parts = comma_fields(text);
    if (parts.size() != 3) throw bad(flag, text, "expected three comma-separated numbers");
    return {parse_number(parts[0], flag), parse_number(parts[1], flag),
            parse_number(parts[2], flag)};
}

ValueType parse_dtype(const std::string& text, const std::string& flag) {
    const auto t = parse_value_type(text);
    if (!t) throw bad(flag, text, "unknown type (use u8, i8, u16, i16, u32, i32, f32 or f64)");
    return *t;
}

std::array<int64_t, 6> parse_box(const std::string& text, const std::string& flag) {
    std::string why;
    const auto box = index_box_from(text, why);
    if (!box) throw bad(flag, text, why);
    return *box;
}

ErrorThreshold parse_error_threshold(const std::string& text, const std::string& flag) {
    std::string why;
    const auto t = error_threshold_from(text, why);
    if (!t) throw bad(flag, text, why);
    return *t;
}

std::function<std::string(const std::string&)> check_with(
    std::function<void(const std::string&)> parse) {
    return [parse](const std::string& text) -> std::string {
        try {
            parse(text);
        } catch (const Error& e) {
            return e.what();
        }
        return {};
    };
}

VolumeReadOptions VolumeFlags::options() const {
    VolumeReadOptions o;
    if (!dims.empty()) o.dims = parse_dims(dims, "--dims");
    if (!dtype.empty()) o.type = parse_dtype(dtype, "--dtype");
    o.endian = endian == "big" ? Endian::Big : Endian::Little;
    o.header_bytes = header_bytes;
    if (!spacing.empty()) o.spacing = parse_vec3(spacing, "--spacing");
    if (!origin.empty()) o.origin = parse_vec3(origin, "--origin");
    o.grid = grid;
    o.axis_order = axis_order;
    o.allow_external_data = allow_external_data;
    return o;
}

void add_volume_flags(CLI::App& sub, VolumeFlags& f) {
    const std::string group =
        "Volume input (" + volume_format_summary() +
        "; raw dims and dtype can come from a name like NAME_XxYxZ_DTYPE.raw)";
    sub.add_option("--dims", f.dims, "Samples per axis X,Y,Z (x varies fastest)")
        ->group(group)
        ->check(check_with([](const std::string& s) { parse_dims(s, ""); }));
    sub.add_option("--dtype", f.dtype, "Sample type: u8|i8|u16|i16|u32|i32|f32|f64")
        ->group(group)
        ->check(check_with([](const std::string& s) { parse_dtype(s, ""); }));
    sub.add_option("--endian", f.endian, "Byte order of multi-byte samples")
        ->group(group)
        ->capture_default_str()
        ->check(CLI::IsMember({"little", "big"}));
    sub.add_option("--header-bytes", f.header_bytes, "Bytes to skip before the samples")
        ->group(group)
        ->capture_default_str();
    sub.add_option("--spacing", f.spacing, "Grid step sx,sy,sz in world units (default 1,1,1)")
        ->group(group)
        ->check(check_with([](const std::string& s) {
            for (double c : parse_vec3(s, ""))
                if (!(c > 0)) throw bad("", s, "every step must be positive");
        }));
    sub.add_option("--origin", f.origin, "World position ox,oy,oz of sample (0,0,0)")
        ->group(group)
        ->check(check_with([](const std::string& s) { parse_vec3(s, ""); }));
    sub.add_option("--grid", f.grid,
                   "OpenVDB: name of the grid to read (default: the only scalar grid)")
        ->group(group);
    sub.add_option("--axis-order", f.axis_order,
                   "HDF5: zyx (C order [z][y][x], default) or xyz (x slowest)")
        ->group(group)
        ->check(CLI::IsMember({"zyx", "xyz"}));
    sub.add_flag("--allow-external-data", f.allow_external_data,
                 "NRRD/MetaImage: read data files the header names outside its folder (absolute paths, ..)")
        ->group(group);
}

Volume load_volume(const std::string& path, const VolumeReadOptions& options) {
    return read_volume(path, options);
}

}  // namespace tetlod::cli

namespace tetlod::cli {

void LodFlags::validate(bool need_error) const {
    if (need_error && !full && error.empty())
        throw Error(ErrorCode::InvalidArgument,
                    "give --error E (e.g. 0.5 or 1%) or --full for the full-resolution mesh");
    if (!error_out.empty() && !has_region())
        throw Error(ErrorCode::InvalidArgument,
                    "--error-out applies outside a region: give --box, --isovalue or another region flag too");
}

ErrorThreshold LodFlags::error_in() const {
    return error.empty() ? ErrorThreshold{} : parse_error_threshold(error, "--error");
}

ErrorThreshold LodFlags::error_out_threshold() const {
    return parse_error_threshold(error_out.empty() ? "inf" : error_out, "--error-out");
}

LodQuery LodFlags::region_query(const Dims* dims) const {
    LodQuery q;
    q.full = full;
    if (!box.empty()) q.box = parse_box(box, "--box");
    for (const auto& s : isovalues) q.isovalues.push_back(parse_number(s, "--isovalue"));
    apply_region_flags(regions, q);
    if (dims) check_box_meets(q, *dims);
    return q;
}

void LodFlags::check_box_meets(const LodQuery& q, const Dims& dims) const {
    // A box that misses the data would silently make the query uniform.
    if (!q.box) return;
    const auto& b = *q.box;
    for (int a = 0; a < 3; ++a)
        if (b[a + 3] < 0 || b[a] > dims[a] - 1)
            throw Error(ErrorCode::InvalidArgument,
                        "--box '" + box + "' lies outside the volume (indices 0.." +
                            std::to_string(dims.x - 1) + ", 0.." + std::to_string(dims.y - 1) +
                            ", 0.." + std::to_string(dims.z - 1) + ")");
}

std::string LodFlags::describe(const LodQuery& q, const std::array<double, 2>& range) const {
    if (full) return "full resolution";
    std::string d = "error <= " + format_error(q.error_in, range);
    if (has_region())
        d += " in the region (" + describe_region(q, box) + "), " + format_error(q.error_out, range) + " elsewhere";
    return d;
}

void add_region_flags(CLI::App& sub, RegionFlags& regions, const std::string& group) {
    for (const QueryRegionKind& kind : query_region_kinds()) {
        const std::string name = kind.name;
        sub.add_option_function<std::string>(
               "--" + name, [&regions, name](const std::string& text) { regions[name] = text; }, kind.help)
            ->group(group)
            ->type_name(kind.syntax)
            ->check(check_with([parse = kind.parse](const std::string& s) { parse(s); }));
    }
}

void apply_region_flags(const RegionFlags& regions, LodQuery& query) {
    for (const auto& [name, text] : regions) {
        const QueryRegionKind* kind = find_query_region_kind(name);
        if (!kind) throw Error(ErrorCode::InvalidArgument, "--" + name + ": no such query region");
        try {
            query.regions.push_back(kind->parse(text));
        } catch (const Error& e) {
            throw Error(e.code(), "--" + name + ": " + e.what());
        }
    }
}

std::string describe_region(const LodQuery& q, const std::string& box_text) {
    std::vector<std::string> parts;
    if (q.box) parts.push_back("box " + box_text);
    if (!q.isovalues.empty()) parts.push_back(std::to_string(q.isovalues.size()) + " isovalue(s)");
    for (const auto& r : q.regions) parts.push_back(r->describe());
    std::string d;
    for (const auto& p : parts) d += (d.empty() ? "" : ", ") + p;
    return d;
}

}  // namespace tetlod::cli

namespace tetlod::cli {

void add_lod_flags(CLI::App& sub, LodFlags& f, const std::string& group,
                   const std::string& error_help, const std::string& full_help) {
    const auto threshold = check_with([](const std::string& s) { parse_error_threshold(s, ""); });
    sub.add_option("--error", f.error, error_help)->group(group)->check(threshold);
    sub.add_option("--error-out", f.error_out, "Largest error outside the region (default inf)")
        ->group(group)
        ->check(threshold);
    sub.add_option("--box", f.box, "Region: index box x0,y0,z0,x1,y1,z1 (inclusive)")
        ->group(group)
        ->check(check_with([](const std::string& s) { parse_box(s, ""); }));
    sub.add_option("--isovalue", f.isovalues,
                   "Region: tets an isosurface at V may cross (repeat or V1,V2)")
        ->group(group)
        ->allow_extra_args(false)  // one value per flag: never swallow the positionals
        ->delimiter(',')
        ->check(check_with([](const std::string& s) { parse_number(s, ""); }));
    add_region_flags(sub, f.regions, group);
    sub.add_flag("--full", f.full, full_help)->group(group);
}

}  // namespace tetlod::cli
