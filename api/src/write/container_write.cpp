// A volume -> a .tlod container holding its HT, its MT or both, with
// provenance metadata (see container.hpp).
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <charconv>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <cmath>
#include <memory>
#include <optional>
#include <vector>

#include "tetlod/analysis/stopwatch.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/output_policy.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/lossy_field.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/container.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/mt/mt_model.hpp"

namespace tetlod {

namespace {

// The creation time: given, else SOURCE_DATE_EPOCH, else now.
std::time_t creation_time(const std::optional<int64_t>& given) {
    if (given) return std::time_t(*given);
    const char* env = std::getenv("SOURCE_DATE_EPOCH");
    if (!env) return std::time(nullptr);
    const std::string text = env;
    int64_t v = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || v < 0 || v > 253402300799)
        throw Error(ErrorCode::InvalidArgument,
                    "SOURCE_DATE_EPOCH='" + text + "': expected seconds since 1970-01-01 (a decimal integer)");
    return std::time_t(v);
}

std::string utc_time(std::time_t t) {
    std::tm tm{};
    gmtime_r(&t, &tm);
    char b[32];
    std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return b;
}

/// `meta`: what the volume says of itself (tlod::metadata_for_volume).
tlod::Metadata with_provenance(tlod::Metadata meta, const ContainerWriteOptions& o) {
    if (!o.source_path.empty()) {
        meta.format_keys[tlod::kKeySourceName] = std::filesystem::path(o.source_path).filename().string();
        if (auto h = tlod::checksum64_file(o.source_path)) {
            char b[24];
            std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(*h));
            meta.format_keys[tlod::kKeySourceXxh64] = b;
            meta.format_keys[tlod::kKeySourceSize] = std::to_string(std::filesystem::file_size(o.source_path));
        }
    }
    meta.format_keys[tlod::kKeyConverter] = o.converter;
    meta.format_keys[tlod::kKeyToolVersion] = TETLOD_VERSION_STRING;
    meta.format_keys[tlod::kKeyCreated] = utc_time(creation_time(o.created));
    return meta;
}

void check_range(const char* what, int value, int lo, int hi) {
    if (value < lo || value > hi)
        throw Error(ErrorCode::InvalidArgument, std::string(what) + " " + std::to_string(value) +
                                                    ": expected " + std::to_string(lo) + ".." +
                                                    std::to_string(hi));
}

void check_options(const ContainerWriteOptions& o) {
    if (!o.ht && !o.mt) throw Error(ErrorCode::InvalidArgument, "write_container: no model requested");
    check_range("zstd level", o.zstd_level, 1, 22);
    check_range("MT large-stream zstd level", o.mt_large_stream_zstd_level, 0, 22);
    check_range("brick_log2", o.brick_log2, 0, 16);
    check_range("error bits", o.error_bits, 0, 7);
    check_range("MT error bits", o.mt_error_bits, 0, 7);
    if (!(o.max_error >= 0) || !std::isfinite(o.max_error))
        throw Error(ErrorCode::InvalidArgument, "max error " + std::to_string(o.max_error) + ": expected a finite value >= 0");
    if (o.max_error > 0 && o.mt && !o.ht)
        throw Error(ErrorCode::InvalidArgument,
                    "a lossy field is stored in the HT: a lossy container holds the HT, or the HT and "
                    "the MT (an MT alone stores its field losslessly)");
    if (o.max_error > 0 && o.ht_errors)
        throw Error(ErrorCode::InvalidArgument, "a lossy container cannot take errors computed elsewhere");
    if (o.fast_decode && o.table != tlod::TableLayout::compact)
        throw Error(ErrorCode::InvalidArgument,
                    "fast decoding (chunk mode 6, format 3.7) needs the compact table: the full one is for "
                    "readers older than 3.2");
    if (o.fast_decode && !o.ht)
        throw Error(ErrorCode::InvalidArgument, "fast decoding codes the HT's field: the container has no HT");
}

/// `o` with an automatic brick size settled for these dims: every write path
/// resolves it once, at its entry, so whole, streamed and distributed writes
/// of one volume code alike.
ContainerWriteOptions with_brick_size(ContainerWriteOptions o, const Dims& dims) {
    if (o.brick_log2 == 0) o.brick_log2 = auto_brick_log2(dims);
    return o;
}

/// The HT encoder's options a container write implies (the one mapping:
/// whole, streamed and distributed writes must code alike). `o` is resolved
/// (with_brick_size).
HtEncodeOptions ht_encode_fields(const ContainerWriteOptions& o) {
    HtEncodeOptions e;
    e.zstd_level = o.zstd_level;
    e.chunk_zstd_level = o.zstd_level;  // "every section": the chunks' fallback frames too
    e.brick_log2 = o.brick_log2;
    e.error_mantissa_bits = o.error_bits;
    e.table = o.table;
    // The full table is for readers older than 3.2: no 3.6 chunk mode either.
    e.range_2d = o.range_2d && o.table == tlod::TableLayout::compact;
    // range_2d false asks for what 3.0-3.5 readers read: no range-exp (3.8) either.
    e.range_exp = e.range_2d;
    e.fast_decode = o.fast_decode;
    return e;
}

HtEncodeOptions encode_options(const ContainerWriteOptions& o) {
    HtEncodeOptions eo = ht_encode_fields(o);
    if (o.progress)
        eo.progress = [&o](std::size_t done, std::size_t total) { o.progress("encode HT", done, total); };
    return eo;
}

/// The MT's options a container write implies.
MtBuildOptions mt_build_options(const ContainerWriteOptions& o) {
    MtBuildOptions mo;
    mo.max_shape_ratio = o.mt_max_shape_ratio;
    if (o.progress)
        mo.progress = [&o](uint64_t done, uint64_t total) { o.progress("build MT", std::size_t(done), std::size_t(total)); };
    return mo;
}
MtEncodeOptions mt_encode_options(const ContainerWriteOptions& o, double field_error) {
    MtEncodeOptions mo;
    mo.zstd_level = o.zstd_level;
    mo.large_stream_zstd_level = o.mt_large_stream_zstd_level;
    mo.error_mantissa_bits = o.mt_error_bits;
    mo.field_error = field_error;
    return mo;
}

/// Lossy archival (format 3.1, HT only): two fields within E of the volume,
/// each encoded, the smaller file kept. One follows the coder's predictions
/// (quantize_predicted: zero residuals in smooth regions, the better one on
/// 8-bit data); the other puts every sample on one lattice (quantize_volume:
/// a piecewise constant field, many zero errors, the better one on floats and
/// wide integers). The padded cube is coded too: there only the second. The
/// lossless file competes as well (its field is within any E and its bounds
/// are exact): on fields the quantizers cannot simplify it is the smallest.
/// With o.mt (format 3.5) the MT is built afterwards on the field kept, so it
/// shares the HT's samples, and its update errors are stored with E added.
ContainerWriteSummary write_lossy_container(Volume volume, const std::string& path, const ContainerWriteOptions& o,
                                           double max_error, const Stopwatch& clock) {
    const tlod::Metadata provenance = with_provenance(tlod::metadata_for_volume(volume), o);
    std::vector<Volume> fields;
    fields.push_back(volume);  // the lossless candidate
    if (!o.pad) {
        fields.push_back(volume);
        quantize_predicted(fields.back(), o.brick_log2, max_error);
    }
    quantize_volume(volume, max_error);
    fields.push_back(std::move(volume));
    HtEncodeOptions eo = encode_options(o);
    eo.max_error = max_error;
    HtBuildOptions bo;
    bo.pad = o.pad;
    std::optional<tlod::ContainerWriter> best;
    std::optional<HtModel> best_model;  // its field is the MT's (o.mt)
    std::size_t best_index = 0;
    ContainerWriteSummary summary;
    // Ties go to the earlier field of the list (lossless, then the predicted
    // one). The lossy fields are encoded first, as they usually win: a later
    // candidate then stops once it is certain not to (give_up_at), which the
    // lossless one, often twice their size, does about halfway.
    std::vector<std::size_t> order;
    for (std::size_t i = 1; i < fields.size(); ++i) order.push_back(i);
    order.push_back(0);
    for (const std::size_t i : order) {
        Volume& f = fields[i];
        eo.max_error = i == 0 ? 0.0 : max_error;
        eo.give_up_at = best ? best->file_size() + (i < best_index ? 1 : 0) : 0;
        if (o.progress) o.progress("build HT", 0, 0);
        tlod::Metadata meta = provenance;
        meta.value_range = tlod::metadata_for_volume(f).value_range;
        const HtModel model = HtModel::build(std::move(f), bo);
        tlod::ContainerWriter w;
        const bool complete = encode_ht(model, meta, w, eo);
        summary.ht_k = model.domain().k;
        summary.ht_max_level = model.domain().max_level();
        if (!complete) continue;
        const uint64_t size = w.file_size();
        if (!best || size < best->file_size() || (size == best->file_size() && i < best_index)) {
            best = std::move(w);
            best_index = i;
            summary.max_error = eo.max_error;
            if (o.mt) best_model.emplace(model);
        }
    }
    if (o.progress) o.progress("encoded HT", 0, 0);
    if (o.mt) {
        // The stored field, as the HT holds it (cropped back to the data when padded).
        const Volume& held = best_model->field();
        Volume stored = held.dims == provenance.dims ? held : crop_volume(held, provenance.dims);
        best_model.reset();
        const MtModel mt = MtModel::build(stored, mt_build_options(o));
        if (o.progress) o.progress("built MT", 0, 0);
        tlod::Metadata meta = provenance;
        meta.value_range = tlod::metadata_for_volume(stored).value_range;
        if (o.progress) o.progress("encode MT", 0, 0);
        encode_mt_container(mt, meta, *best, true, mt_encode_options(o, summary.max_error));
        if (o.progress) o.progress("encoded MT", 0, 0);
        summary.mt_updates = mt.updates().size();
        summary.mt_base_tets = mt.base_tets().size();
    }
    best->write(path);
    std::error_code size_error;  // "-" (standard output) has no size
    summary.bytes = std::filesystem::file_size(path, size_error);
    summary.seconds = clock.seconds();
    return summary;
}

HtStreamEncodeOptions stream_options(const ContainerWriteOptions& o) {
    HtStreamEncodeOptions so;
    so.pad = o.pad;
    check_options(o);
    so.encode = ht_encode_fields(o);
    so.memory_bytes = o.memory_bytes ? o.memory_bytes : default_memory_budget();
    so.errors = o.ht_errors;
    if (o.progress)
        so.progress = [&o](const char* stage, uint64_t done, uint64_t total) {
            o.progress(std::string(stage) + " HT", std::size_t(done), std::size_t(total));
        };
    return so;
}

/// A candidate file of the bounded lossy path, removed unless kept: beside the
/// output (same file system, where the user agreed to write), or in the
/// temporary directory when the output is not a regular file ("-", a FIFO).
class CandidateFile {
public:
    CandidateFile(const std::string& output, int index) {
        namespace fs = std::filesystem;
        std::error_code ec;
        const fs::path out(output);
        const bool beside = output != "-" && (!fs::exists(out, ec) || fs::is_regular_file(out, ec));
        const fs::path dir = beside ? (out.has_parent_path() ? out.parent_path() : fs::path(".")) : fs::temp_directory_path();
        path_ = (dir / (".tetlod-lossy-" + std::to_string(::getpid()) + "-" + std::to_string(index) + ".tlod")).string();
    }
    ~CandidateFile() {
        std::error_code ec;
        std::filesystem::remove(path_, ec);
    }
    CandidateFile(const CandidateFile&) = delete;
    CandidateFile& operator=(const CandidateFile&) = delete;
    const std::string& path() const { return path_; }

private:
    std::string path_;
};

/// Copies a finished candidate to the output atomically (the output policy is
/// consulted there, as for any output).
void copy_to_output(const std::string& from, const std::string& to) {
    std::FILE* in = std::fopen(from.c_str(), "rb");
    if (!in) throw Error(ErrorCode::IoError, "'" + from + "': cannot open the candidate container");
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> closer(in, &std::fclose);
    AtomicFile out(to);
    std::vector<char> block(std::size_t{1} << 20);
    while (const std::size_t n = std::fread(block.data(), 1, block.size(), in)) out.write(block.data(), n);
    if (std::ferror(in)) throw Error(ErrorCode::IoError, "'" + from + "': read error");
    out.commit();
}

/// Lossy archival in bounded memory (the VolumePlanes overload, when the
/// whole-volume path would exceed the budget): the lossless field and the
/// lattice field (quantized_planes, plane by plane) are each streamed to a
/// candidate file, and the smaller is copied to the output. The field that
/// follows the coder's predictions needs the whole volume in the coder's order
/// and is not tried, so the file may be larger than the whole-volume path's.
ContainerWriteSummary write_lossy_streaming(VolumePlanes& source, const std::string& path,
                                           const ContainerWriteOptions& o, double max_error,
                                           const Stopwatch& clock) {
    check_output(path);  // an output refused is refused before the work, as other writers do
    const tlod::Metadata meta = container_metadata(source.header(), o);
    const std::unique_ptr<VolumePlanes> lattice = quantized_planes(source, max_error);
    ContainerWriteSummary summary;
    std::optional<CandidateFile> files[2];
    int best = 0;
    uint64_t best_bytes = 0;
    for (int i = 0; i < 2; ++i) {
        files[i].emplace(path, i);
        HtStreamEncodeOptions so = stream_options(o);
        so.encode.max_error = i == 0 ? 0.0 : max_error;
        // Scratch files: written under a policy of their own, so the caller's
        // lists only the output (new names, so nothing to refuse).
        OutputPolicy scratch;
        std::optional<ScopedOutputPolicy> own(std::in_place, scratch);
        const HtStreamEncodeSummary s =
            write_ht_container_streaming(i == 0 ? source : *lattice, meta, files[i]->path(), so);
        own.reset();
        summary.ht_k = s.domain.k;
        summary.ht_max_level = s.domain.max_level();
        const uint64_t bytes = std::filesystem::file_size(files[i]->path());
        if (i == 0 || bytes < best_bytes) {  // ties go to the lossless file
            best = i;
            best_bytes = bytes;
            summary.max_error = so.encode.max_error;
        }
    }
    if (o.progress) o.progress("encoded HT", 0, 0);
    copy_to_output(files[best]->path(), path);
    std::error_code size_error;  // "-" (standard output) has no size
    summary.bytes = std::filesystem::file_size(path, size_error);
    summary.seconds = clock.seconds();
    return summary;
}

}  // namespace

std::size_t default_memory_budget() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
    const std::size_t physical = pages > 0 && page > 0 ? std::size_t(pages) * std::size_t(page) : 0;
    return std::max<std::size_t>(physical / 4, std::size_t{256} << 20);
}

bool lossy_reads_whole(const Volume& header, std::size_t memory_bytes) {
    // What write_lossy_container holds at its peak, about: the volume and its
    // two quantized copies, a model's float bounds and the encoded candidate.
    const std::size_t points = std::size_t(header.dims.count());
    const std::size_t whole = 4 * points * value_size(header.type) + 4 * points;
    return whole <= (memory_bytes ? memory_bytes : default_memory_budget());
}

tlod::Metadata container_metadata(const Volume& header, const ContainerWriteOptions& o) {
    return with_provenance(tlod::metadata_for_volume(header, {0, 0}), o);
}

int auto_brick_log2(const Dims& dims) {
    return std::max({dims.x, dims.y, dims.z}) <= 129 ? 5 : 4;
}

HtEncodeOptions container_ht_encode_options(const ContainerWriteOptions& options, const Volume& header) {
    const ContainerWriteOptions o = with_brick_size(options, header.dims);
    check_options(o);
    return ht_encode_fields(o);
}

ContainerWriteSummary write_container(VolumePlanes& source, const std::string& path,
                                      const ContainerWriteOptions& options) {
    const ContainerWriteOptions o = with_brick_size(options, source.header().dims);
    check_options(o);
    // The MT is built from the whole volume: a lossy request with it reads it whole.
    const double max_error = stored_max_error(source.header().type, o.max_error);
    if (max_error > 0 && !o.mt && !lossy_reads_whole(source.header(), o.memory_bytes))
        return write_lossy_streaming(source, path, o, max_error, Stopwatch());
    if (o.mt || o.max_error > 0) {
        // The MT is built from the whole volume, and the lossy field is chosen
        // in the coder's order over the whole volume (when that fits the
        // budget): read it, then the usual path.
        return write_container(read_all_planes(source), path, o);
    }
    Stopwatch clock;
    // The value range is filled in by the encoder's first pass.
    const tlod::Metadata meta = container_metadata(source.header(), o);
    const HtStreamEncodeSummary s = write_ht_container_streaming(source, meta, path, stream_options(o));
    if (o.progress) o.progress("encoded HT", 0, 0);
    ContainerWriteSummary summary;
    summary.ht_k = s.domain.k;
    summary.ht_max_level = s.domain.max_level();
    std::error_code size_error;  // "-" (standard output) has no size
    summary.bytes = std::filesystem::file_size(path, size_error);
    summary.seconds = clock.seconds();
    return summary;
}

ContainerWriteSummary write_container(Volume volume, const std::string& path, const ContainerWriteOptions& options) {
    const ContainerWriteOptions o = with_brick_size(options, volume.dims);
    check_options(o);
    Stopwatch clock;
    // Lossy (before the range is recorded): integers can only honour floor(E),
    // so that is the bound stated (0: the lossless file, exact bounds).
    const double max_error = stored_max_error(volume.type, o.max_error);
    if (max_error > 0) return write_lossy_container(std::move(volume), path, o, max_error, clock);
    auto progress = [&](const char* stage, std::size_t done, std::size_t total) {
        if (o.progress) o.progress(stage, done, total);
    };
    const tlod::Metadata meta = with_provenance(tlod::metadata_for_volume(volume), o);
    ContainerWriteSummary summary;
    tlod::ContainerWriter w;
    w.set_table(o.table);
    std::optional<MtModel> mt;
    if (o.mt) {
        mt = MtModel::build(volume, mt_build_options(o));
        progress("built MT", 0, 0);
    }
    if (o.ht) {
        progress("build HT", 0, 0);
        HtBuildOptions bo;
        bo.pad = o.pad;
        const HtModel model = HtModel::build(std::move(volume), bo);
        progress("built HT", 0, 0);
        encode_ht(model, meta, w, encode_options(o));
        progress("encoded HT", 0, 0);
        summary.ht_k = model.domain().k;
        summary.ht_max_level = model.domain().max_level();
    }
    if (mt) {
        progress("encode MT", 0, 0);
        encode_mt_container(*mt, meta, w, o.ht, mt_encode_options(o, 0));
        progress("encoded MT", 0, 0);
        summary.mt_updates = mt->updates().size();
        summary.mt_base_tets = mt->base_tets().size();
    }
    w.write(path);
    std::error_code size_error;  // "-" (standard output) has no size
    summary.bytes = std::filesystem::file_size(path, size_error);
    summary.seconds = clock.seconds();
    return summary;
}

}  // namespace tetlod
