#pragma once
// The compressors bench_container measures .tlod against (issue 13), each
// behind one call: compress a volume, decompress it, check what came back,
// and time both directions in MB/s of raw samples. One file per peer.
#include <chrono>
#include <cstdint>
#include <string>

#include "tetlod/core/volume.hpp"

namespace tetlod::bench {

struct PeerResult {
    bool available = false;  // false: the peer was not built in (why says so)
    std::string why;
    uint64_t bytes = 0;      // compressed size, headers and file framing included
    double encode_mbs = 0, decode_mbs = 0;  // raw bytes per second / 1e6
    bool exact = false;      // decoded bit-exact
    double max_error = 0;    // largest |decoded - original| (lossy peers)
};

/// Seconds per call of `f`, repeated until `min_seconds` have passed (at
/// least once): small volumes are timed over many calls.
template <class F>
double seconds_per_call(F&& f, double min_seconds) {
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    int calls = 0;
    double s = 0;
    do {
        f();
        ++calls;
        s = std::chrono::duration<double>(Clock::now() - t0).count();
    } while (s < min_seconds);
    return s / calls;
}

/// zstd at `level` with long-distance matching and a 2^window_log window
/// (`zstd -19 --long=27`), one frame, through libzstd.
PeerResult run_zstd(const Volume& v, int level, int window_log, double min_seconds);

/// HDF5 through the library's writer (tetlod::write_hdf5): one chunked dataset,
/// shuffle + deflate at `level`, written to a file in `tmp_dir`; its size is the
/// whole file's (attributes included, as an archivist would store it).
PeerResult run_hdf5_gzip(const Volume& v, int level, const std::string& tmp_dir, double min_seconds);

/// zfp (libzfp, 3-D, full header): reversible, or fixed accuracy `tolerance`
/// (absolute). Integer volumes go through int32 (reversible) or float (fixed
/// accuracy; exact for 8- and 16-bit samples). Unavailable without libzfp.
PeerResult run_zfp_reversible(const Volume& v, double min_seconds);
PeerResult run_zfp_accuracy(const Volume& v, double tolerance, double min_seconds);

/// The .tlod container (HT: field + errors + hierarchy, default options) written
/// by tetlod::write_container and read back by tetlod::decode_container, with
/// where its bytes went (tetlod::inspect_container's section coders).
struct TlodResult : PeerResult {
    uint64_t field_bytes = 0, error_bytes = 0, other_bytes = 0;  // other: metadata, headers, table
    /// Format 3.2 (spec §4.4): the compact table written, the 48-byte entries
    /// it replaced (the same file with --table full is bytes - table + full_table),
    /// and the sections holding bytes (each keeps an 8-byte checksum).
    uint64_t table_bytes = 0, full_table_bytes = 0, nonempty_sections = 0;
};
TlodResult run_tlod(const Volume& v, const std::string& tmp_dir, double min_seconds);
/// The lossy .tlod (format 3.1, write_container with max_error): bytes, and
/// max_error the largest |decoded - original| (checked against the bound by the caller).
TlodResult run_tlod_lossy(const Volume& v, double max_error, const std::string& tmp_dir, double min_seconds);
/// The lossless .tlod written for decoding speed (`convert --fast-decode`:
/// static-table chunks, format 3.7).
TlodResult run_tlod_fast(const Volume& v, const std::string& tmp_dir, double min_seconds);

}  // namespace tetlod::bench
