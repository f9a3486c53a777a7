// tetlod-mpi: the distributed converter, run under mpirun. Two subcommands,
// `convert FILE.h5:/dataset out.tlod` and `decode in.tlod FILE.h5:/dataset`,
// with the flags of `tetlod convert` and `tetlod decode` that apply to them and
// the same exit codes (exit_code.hpp). The work is in mpi/src.
//
// Why a program of its own rather than `mpirun tetlod convert`: it links the
// parallel libhdf5 (MPI-IO), and `tetlod` links the serial one; the two export
// the same symbols, so one process must never load both. Keeping MPI out of
// `tetlod` also keeps it runnable without an MPI runtime (MPI_Init, a launcher,
// libmpi at load time) and unchanged when built without MPI.
#include <mpi.h>
#include <sched.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <memory>
#include <sstream>

#include "byte_size.hpp"
#include "cli_parse.hpp"
#include "exit_code.hpp"
#include "mpi_convert.hpp"
#include "mpi_decode.hpp"
#include "mpi_extract.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/core/utf8.hpp"

namespace {

using namespace tetlod;

struct Args {
    std::string input, output;
    bool pad = false, force = false, quiet = false;
    int verbose = 0;
    std::vector<std::string> meta;
    int level = 19, brick_log2 = 0, error_bits = 4;  // brick_log2 0: automatic
    std::string memory, axis_order;
    std::string table = "compact";  // convert: section table layout
    bool fast_decode = false;        // convert: static-table field chunks (format 3.7)
    // extract
    std::string error, error_out, box, format, compress = "zlib";
    int compress_level = 0;
    uint64_t cache_mb = 1024;
};

// --error, --error-out and --box accept and refuse what `tetlod extract` does
// (tools/cli_parse.hpp); a refusal names the flag and the text.
Error bad_flag(const std::string& flag, const std::string& text, const std::string& why) {
    return Error(ErrorCode::InvalidArgument, (flag.empty() ? "" : flag + " ") + "'" + text + "': " + why);
}

cli::ErrorThreshold parse_threshold(const std::string& text, const std::string& flag) {
    std::string why;
    const auto t = cli::error_threshold_from(text, why);
    if (!t) throw bad_flag(flag, text, why);
    return *t;
}

std::array<int64_t, 6> parse_box(const std::string& text) {
    std::string why;
    const auto box = cli::index_box_from(text, why);
    if (!box) throw bad_flag("--box", text, why);
    return *box;
}

// A CLI11 check (exit 2 before any work); CLI11 prefixes the option's name.
template <class Parse>
std::function<std::string(const std::string&)> check_text(Parse parse) {
    return [parse](const std::string& text) -> std::string {
        std::string why;
        return parse(text, why) ? std::string() : bad_flag("", text, why).what();
    };
}

void check_meta(const std::vector<std::string>& meta) {
    for (const std::string& kv : meta) {
        const auto eq = kv.find('=');
        if (eq == std::string::npos || eq == 0)
            throw Error(ErrorCode::InvalidArgument, "--meta '" + kv + "': expected key=value");
        if (const std::size_t bad = first_invalid_utf8(kv); bad != kv.size())
            throw Error(ErrorCode::InvalidArgument, "--meta: entry " + std::to_string(&kv - meta.data() + 1) +
                                                        " is not valid UTF-8 (byte " + std::to_string(bad) +
                                                        " of the argument); give UTF-8 text");
    }
}

// Rank 0 runs the encoder on every core its affinity allows; launchers pin
// ranks to one core by default (Open MPI: --bind-to core for 2 ranks), which
// made 2 ranks take twice as long as 1 on a 513^3 volume. Said, not undone:
// the placement is the user's.
void warn_if_pinned() {
    cpu_set_t set;
    CPU_ZERO(&set);
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    if (sched_getaffinity(0, sizeof set, &set) != 0 || online <= 1) return;
    const int allowed = CPU_COUNT(&set);
    if (allowed < online)
        std::cerr << "tetlod-mpi: note: rank 0 encodes with threads and may use " << allowed << " of " << online
                  << " cores here; give it the node (mpirun --bind-to none, or one rank per node)\n";
}

// The exit code of an agreed failure, as `tetlod` maps the same error.
int exit_code_of(const mpi::RankFailure& f) { return f.internal ? 1 : exit_code_for(f.code); }

// Rank 0 prints the agreed failure; every rank returns its exit code.
int report_failure(const mpi::RankFailure& f, int rank) {
    if (rank == 0) {
        const std::string where = f.rank != 0 ? "rank " + std::to_string(f.rank) + ": " : "";
        std::cerr << "tetlod-mpi: " << (f.internal ? "internal error: " : "error: ") << where << f.message << "\n";
    }
    return exit_code_of(f);
}

int run_decode(const Args& a, int rank, int size) {
    mpi::MpiDecodeOptions o;
    o.force = a.force;
    const char* phase = std::getenv("TETLOD_MPI_TEST_FAIL_PHASE");
    if (const char* f = std::getenv("TETLOD_MPI_TEST_FAIL_RANK"); f && phase && std::string(phase) == "decode")
        o.fail_rank = std::atoi(f);
    const double t0 = MPI_Wtime();
    const mpi::MpiDecodeResult r = mpi::decode_mpi(MPI_COMM_WORLD, a.input, a.output, o);
    if (r.failure) return report_failure(*r.failure, rank);
    if (rank != 0 || a.quiet) return 0;
    if (!r.lost_keys.empty()) {  // as `tetlod decode` warns
        std::string keys;
        for (const auto& k : r.lost_keys) keys += (keys.empty() ? "'" : ", '") + k + "'";
        std::cerr << "tetlod-mpi: warning: '" << a.output << "' cannot hold metadata " << keys << "; written without "
                  << (r.lost_keys.size() == 1 ? "it" : "them") << "\n";
    }
    const Dims d = r.header.dims;
    std::cout << "wrote " << a.output << ": " << d.x << "x" << d.y << "x" << d.z << " "
              << value_type_name(r.header.type) << ", " << size << (size == 1 ? " rank" : " ranks") << ", "
              << MPI_Wtime() - t0 << " s\n";
    if (a.verbose > 0) {
        std::cerr << "rank  planes       bytes written  decode s  write s  user CPU s  peak RSS MB\n";
        for (std::size_t i = 0; i < r.traffic.size(); ++i) {
            const auto& t = r.traffic[i];
            char planes[40] = "none";  // more ranks than rows of bricks
            if (t.planes > 0)
                std::snprintf(planes, sizeof planes, "%lld..%lld", (long long)t.z0, (long long)(t.z0 + t.planes - 1));
            char row[200];
            std::snprintf(row, sizeof row, "%4zu %-12s %13llu %9.3f %8.3f %11.3f %12.1f\n", i, planes,
                          (unsigned long long)t.bytes_written, t.decode_seconds, t.write_seconds, t.cpu_seconds,
                          t.peak_rss_mb);
            std::cerr << row;
        }
    }
    return 0;
}

int run_extract(const Args& a, int rank, int size) {
    if (!a.error_out.empty() && a.box.empty())
        throw Error(ErrorCode::InvalidArgument, "--error-out applies outside a region: give --box too");
    mpi::MpiExtractOptions o;
    o.force = a.force;
    o.format = a.format;
    o.write.compression = *parse_mesh_compression(a.compress);
    o.write.compression_level = a.compress_level;
    o.cache_bytes = std::size_t(a.cache_mb) << 20;
    if (!a.box.empty()) o.query.box = parse_box(a.box);
    const cli::ErrorThreshold in = parse_threshold(a.error, "--error");
    const cli::ErrorThreshold outside = parse_threshold(a.error_out.empty() ? "inf" : a.error_out, "--error-out");
    o.resolve = [in, outside](LodQuery& q, const std::array<double, 2>& range) {
        q.error_in = in.resolve(range);
        q.error_out = outside.resolve(range);
    };
    const char* phase = std::getenv("TETLOD_MPI_TEST_FAIL_PHASE");
    if (const char* f = std::getenv("TETLOD_MPI_TEST_FAIL_RANK"); f && phase && std::string(phase) == "extract")
        o.fail_rank = std::atoi(f);
    const double t0 = MPI_Wtime();
    const mpi::MpiExtractResult r = mpi::extract_mpi(MPI_COMM_WORLD, a.input, a.output, o);
    if (r.failure) return report_failure(*r.failure, rank);
    if (rank != 0 || a.quiet) return 0;
    const Dims d = r.dims;
    std::cout << "wrote " << a.output << ": " << r.tets << " tets, " << r.vertices << " vertices, largest error "
              << r.max_error << " (from " << d.x << "x" << d.y << "x" << d.z << " " << value_type_name(r.type)
              << "), " << size << (size == 1 ? " rank" : " ranks") << ", " << MPI_Wtime() - t0 << " s\n";
    if (a.verbose > 0) {
        std::cerr << "rank         tets  chunks    bytes sent  bytes received  messages  refine s  emit s  user CPU s  "
                     "peak RSS MB\n";
        for (std::size_t i = 0; i < r.traffic.size(); ++i) {
            const auto& t = r.traffic[i];
            char row[200];
            std::snprintf(row, sizeof row, "%4zu %12llu %7llu %13llu %15llu %9llu %9.3f %7.3f %11.3f %12.1f\n", i,
                          (unsigned long long)t.tets, (unsigned long long)t.chunks_decoded,
                          (unsigned long long)t.bytes_sent, (unsigned long long)t.bytes_received,
                          (unsigned long long)t.messages, t.refine_seconds, t.emit_seconds, t.cpu_seconds,
                          t.peak_rss_mb);
            std::cerr << row;
        }
    }
    return 0;
}

int run(const Args& a, int rank, int size) {
    check_meta(a.meta);
    mpi::MpiConvertOptions o;
    o.write.pad = a.pad;
    o.write.zstd_level = a.level;
    o.write.brick_log2 = a.brick_log2;
    o.write.error_bits = a.error_bits;
    o.write.table = a.table == "full" ? tlod::TableLayout::full : tlod::TableLayout::compact;
    o.write.fast_decode = a.fast_decode;
    o.write.memory_bytes = default_memory_budget();
    if (!a.memory.empty()) {
        std::string why;
        const auto bytes = cli::byte_size_from(a.memory, why);
        if (!bytes) throw Error(ErrorCode::InvalidArgument, "--memory '" + a.memory + "': " + why);
        o.write.memory_bytes = *bytes;
    }
    // Recorded as `tetlod convert` writes it: the container is that one, byte for byte.
    o.write.source_path = a.input;
    o.write.converter = "tetlod convert";
    o.read.axis_order = a.axis_order;
    o.force = a.force;
    for (const std::string& kv : a.meta) o.meta[kv.substr(0, kv.find('='))] = kv.substr(kv.find('=') + 1);
    if (const char* f = std::getenv("TETLOD_MPI_TEST_FAIL_RANK")) o.fail_rank = std::atoi(f);
    if (const char* f = std::getenv("TETLOD_MPI_TEST_FAIL_PHASE")) o.fail_phase = f;

    if (rank == 0 && !a.quiet) warn_if_pinned();
    const double t0 = MPI_Wtime();
    const mpi::MpiConvertResult r = mpi::convert_mpi(MPI_COMM_WORLD, a.input, a.output, o);
    if (r.failure) return report_failure(*r.failure, rank);
    if (rank == 0 && !a.quiet) {
        std::ostringstream line;
        line << "wrote " << a.output << ": " << r.summary.bytes << " bytes, HT k = " << r.summary.ht_k
             << ", levels 0.." << r.summary.ht_max_level << ", " << size << (size == 1 ? " rank" : " ranks") << ", "
             << MPI_Wtime() - t0 << " s\n";
        // "-": the container goes to standard output, the report to stderr.
        (a.output == "-" ? std::cerr : std::cout) << line.str();
        if (a.verbose > 0) {
            std::cerr << "rank  bytes read  bytes sent  bytes received  bytes written  messages  read s  scan s  errors s  "
                         "encode s  user CPU s\n";
            for (std::size_t i = 0; i < r.traffic.size(); ++i) {
                const auto& t = r.traffic[i];
                char row[200];
                std::snprintf(row, sizeof row, "%4zu %11llu %11llu %15llu %14llu %9llu %7.3f %7.3f %9.3f %9.3f %11.3f\n",
                              i, (unsigned long long)t.bytes_read, (unsigned long long)t.bytes_sent,
                              (unsigned long long)t.bytes_received, (unsigned long long)t.bytes_written,
                              (unsigned long long)t.messages, t.read_seconds, t.scan_seconds, t.error_seconds,
                              t.encode_seconds, t.cpu_seconds);
                std::cerr << row;
            }
        }
    }
    return 0;
}

int main_mpi(int argc, char** argv, int rank, int size) {
    CLI::App app{"tetlod-mpi: distributed conversion of HDF5 volumes to .tlod containers and back, and mesh extraction (run under mpirun)"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("tetlod-mpi ") + TETLOD_VERSION_STRING);
    Args a;
    app.add_flag("-q,--quiet", a.quiet, "Print only errors");
    app.add_flag("-v,--verbose", a.verbose, "Print what each rank read and sent");
    app.add_flag("-f,--force", a.force, "Replace an existing output");
    app.footer("Exit codes: 0 ok, 2 bad usage, 3 I/O error or missing file/dataset, 4 bad input data.\n"
               "Every rank exits with the same code; rank 0 prints the error.");
    CLI::App* convert = app.add_subcommand(
        "convert", "HDF5 dataset -> .tlod container (HT), byte for byte what `tetlod convert` writes");
    convert->add_option("input", a.input, "Input FILE.h5:/dataset (FILE.h5 alone: its only dataset)")->required();
    convert->add_option("output", a.output, "Output .tlod file (written by every rank into a temporary file, renamed at the end)")->required();
    convert->add_option("--axis-order", a.axis_order, "zyx (C order [z][y][x], default) or xyz (x slowest)")
        ->check(CLI::IsMember({"zyx", "xyz"}));
    convert->add_flag("--pad", a.pad, "Embed the data in the enclosing (2^k+1)^3 cube");
    convert->add_option("--memory", a.memory, "Accepted for compatibility and checked; unused since every rank encodes its own rows (memory: docs/distributed.md)");
    convert->add_option("--meta", a.meta, "User metadata key=value (repeatable)");
    convert->add_option("--level", a.level, "zstd level of every section")->capture_default_str()->check(CLI::Range(1, 22));
    convert->add_option("--brick-log2", a.brick_log2,
                        "Bricks of cycle t span 2^(t+1+N) grid steps; 0: 5 when no axis has more than 129 samples, "
                        "else 4 (as tetlod convert)")
        ->capture_default_str()
        ->check(CLI::Range(0, 16));
    convert->add_option("--table", a.table, "Section table layout: compact (format 3.2) or full (a 3.0 file for older readers, no range-2d chunks)")
        ->capture_default_str()
        ->check(CLI::IsMember({"compact", "full"}));
    convert->add_flag("--fast-decode", a.fast_decode,
                      "Code the HT's field for decoding speed (static-table chunks, format 3.7): faster to decode, larger");
    convert->add_option("--error-bits", a.error_bits, "Mantissa bits of stored error bounds")
        ->capture_default_str()
        ->check(CLI::Range(0, 7));
    convert->footer("Examples:\n"
                    "  mpirun -n 4 --bind-to none tetlod-mpi convert scan.h5:/volume scan.tlod   # every rank encodes with threads\n"
                    "  SOURCE_DATE_EPOCH=0 mpirun -n 2 tetlod-mpi convert scan.h5:/volume scan.tlod  # reproducible");
    CLI::App* decode = app.add_subcommand(
        "decode", ".tlod container -> HDF5 dataset, the dataset `tetlod decode` writes (values and attributes)");
    decode->add_option("input", a.input, "Input .tlod file (holding the HT)")->required();
    decode->add_option("output", a.output,
                       "Output FILE.h5:/dataset (FILE.h5 alone: /volume); an existing file keeps its other datasets")
        ->required();
    decode->footer("Every rank decodes its slab of planes (rows of the finest bricks) and writes it with\n"
                   "collective hyperslab writes into a temporary copy of the file, renamed at the end.\n"
                   "Examples:\n"
                   "  mpirun -n 4 tetlod-mpi decode scan.tlod scan.h5:/volume\n"
                   "  mpirun -n 2 tetlod-mpi -f decode scan.tlod scans.h5:/run2/volume   # replace that dataset");
    CLI::App* extract = app.add_subcommand(
        "extract", ".tlod container (HT) -> level-of-detail mesh, the file `tetlod extract` writes");
    extract->add_option("input", a.input, "Input .tlod file (holding the HT)")->required();
    extract->add_option("output", a.output, "Output mesh (.vtu, .vtk, .msh; written by rank 0, atomically)")->required();
    extract->add_option("--error", a.error, "Largest error allowed (inside the box if any): E, N% of the value range, inf, or negative = full resolution")
        ->required()
        ->check(check_text(cli::error_threshold_from));
    extract->add_option("--error-out", a.error_out, "Largest error outside the box (default inf)")
        ->check(check_text(cli::error_threshold_from));
    extract->add_option("--box", a.box, "Region x0,y0,z0,x1,y1,z1 (sample indices, inclusive)")
        ->check(check_text(cli::index_box_from));
    extract->add_option("--format", a.format, "Mesh format (default: from the extension)")
        ->check(CLI::IsMember(mesh_format_names()));
    extract->add_option("--compress", a.compress, "Block compressor of .vtu arrays: zlib, lz4, lzma or none")
        ->capture_default_str()
        ->check(CLI::IsMember({"lz4", "zlib", "lzma", "none"}));
    extract->add_option("--compress-level", a.compress_level, "Compressor level 1..9; 0: its default")
        ->check(CLI::Range(0, 9));
    extract->add_option("--cache-mb", a.cache_mb, "Memory for decoded chunks per rank, in MiB")
        ->capture_default_str()
        ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 30));
    extract->footer("Every rank computes the refinement (the split set) and emits an equal share of the tets;\n"
                    "rank 0 writes the file through the serial writer, the same bytes as `tetlod extract`.\n"
                    "Examples:\n"
                    "  mpirun -n 4 tetlod-mpi extract scan.tlod scan.vtu --error 1%\n"
                    "  mpirun -n 2 tetlod-mpi extract scan.tlod roi.vtu --error 0 --box 64,64,20,192,192,80 --error-out 5%");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // Every rank parses the same arguments; rank 0 alone speaks.
        if (rank != 0) return e.get_exit_code() == 0 ? 0 : 2;
        if (e.get_exit_code() == 0) return app.exit(e);
        std::cerr << "tetlod-mpi: error: " << e.what() << "\nRun 'tetlod-mpi --help' for usage.\n";
        return 2;
    }
    try {
        if (extract->parsed()) return run_extract(a, rank, size);
        return decode->parsed() ? run_decode(a, rank, size) : run(a, rank, size);
    } catch (const Error& e) {  // before any collective step (bad flags): the same on every rank
        if (rank == 0) std::cerr << "tetlod-mpi: error: " << e.what() << "\n";
        return exit_code_for(e.code());
    }
}

}  // namespace

int main(int argc, char** argv) {
    // Serialized: the encoder may fetch planes from a worker thread, one at a time.
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    const int code = main_mpi(argc, argv, rank, size);
    MPI_Finalize();
    return code;
}
