// The archivist's comparison (issue 13), per volume in one run: every real
// dataset (directory: argument, else $TETLOD_DATA_DIR, else shared/data beside
// the checkout) and generated sparse, constant, noisy and float volumes. Sizes:
// raw, zstd -19 --long=27, HDF5 gzip-9 + shuffle, zfp reversible and zfp fixed
// accuracy at 0.1% and 1% of the value range (bound checked on decode), and the
// lossless .tlod (field + errors + hierarchy), its ratio to zstd-19 and where
// its bytes go; then encode and decode MB/s of each; the lossy .tlod (format
// 3.1) at 0.1% and 1% of the range against the lossless one and zstd-19; the
// lossless .tlod written for decoding speed (--fast-decode, format 3.7). Then the bytes read for a coarse LOD and a small full-resolution box on
// a 257^3 sample. Usage: bench_container [DATA_DIR] [--quick]
// (--quick: generated volumes at 33^3, each timing one call, no 257^3 part).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "peer.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/converters/sample_volumes.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

using namespace tetlod;
using namespace tetlod::bench;
using Clock = std::chrono::steady_clock;

static double secs(Clock::time_point a) {
    return std::chrono::duration<double>(Clock::now() - a).count();
}

static bool load_raw(const std::filesystem::path& p, Volume& v) {
    static const std::regex re(R"(.*_(\d+)x(\d+)x(\d+)_([a-z0-9]+)\.raw)");
    std::smatch m;
    const std::string name = p.filename().string();
    if (!std::regex_match(name, m, re)) return false;
    auto t = parse_value_type(m[4].str());
    if (!t) return false;
    v = Volume::allocate(Dims{std::stoll(m[1]), std::stoll(m[2]), std::stoll(m[3])}, *t);
    std::ifstream in(p, std::ios::binary);
    in.read(reinterpret_cast<char*>(v.data.data()), std::streamsize(v.data.size()));
    return bool(in);
}

struct Row {
    std::string name;
    Volume volume;
};

struct Measured {
    std::string name;
    uint64_t raw = 0;
    double range = 0;
    PeerResult zstd, hdf5, zfp_rev, zfp_fine, zfp_coarse;
    TlodResult tlod, lossy_fine, lossy_coarse;  // lossless; lossy at 0.1% and 1% of the range
    TlodResult fast;                            // lossless, --fast-decode (format 3.7)
};

// A size cell: bytes, "n/a" when the peer is missing, "!" after a lossless
// peer that did not come back bit-exact or a lossy one beyond its bound.
static std::string size_cell(const PeerResult& r, bool lossless, double bound = 0) {
    if (!r.available) return "n/a";
    std::string s = std::to_string(r.bytes);
    if (lossless ? !r.exact : r.max_error > bound) s += "!";
    return s;
}

static std::string speed_cell(const PeerResult& r) {
    if (!r.available) return "n/a";
    char b[32];
    std::snprintf(b, sizeof b, "%.0f/%.0f", r.encode_mbs, r.decode_mbs);
    return b;
}

int main(int argc, char** argv) {
    std::string dir = std::getenv("TETLOD_DATA_DIR") ? std::getenv("TETLOD_DATA_DIR") : TETLOD_DEFAULT_DATA_DIR;
    bool quick = false;
    for (int i = 1; i < argc; ++i) {
        if (std::string(argv[i]) == "--quick") quick = true;
        else dir = argv[i];
    }
    const double min_seconds = quick ? 0 : 0.2;
    const std::string tmp = std::filesystem::temp_directory_path().string();

    std::vector<Row> rows;
    std::vector<std::filesystem::path> files;
    if (std::filesystem::is_directory(dir))
        for (auto& e : std::filesystem::directory_iterator(dir))
            if (e.path().extension() == ".raw") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& p : files) {
        Row r{p.stem().string(), {}};
        if (load_raw(p, r.volume)) rows.push_back(std::move(r));
    }
    // Generated cases (converters/sample_volumes.hpp): 129^3 for the integer
    // ones (bucky 128^3's size), 65^3 for the float ones.
    const int64_t gi = quick ? 33 : 129, gf = quick ? 33 : 65;
    const struct { const char* sample; int64_t n; ValueType type; } generated[] = {
        {"sparse", gi, ValueType::U8},          {"constant", gi, ValueType::U8},
        {"noisy", gi, ValueType::U8},           {"multiscale", gf, ValueType::U16},
        {"multiscale", gf, ValueType::F32},     {"noisy", gf, ValueType::F32},
    };
    for (const auto& g : generated) {
        const Dims d{g.n, g.n, g.n};
        rows.push_back({"gen:" + std::string(g.sample) + "_" + std::to_string(g.n) + "^3_" +
                            value_type_name(g.type),
                        make_sample_volume(g.sample, d, g.type)});
    }

    std::vector<Measured> ms;
    for (const Row& row : rows) {
        const Volume& v = row.volume;
        Measured m;
        m.name = row.name;
        m.raw = v.data.size();
        const auto range = v.range();
        m.range = range[1] - range[0];
        m.zstd = run_zstd(v, 19, 27, min_seconds);
        m.hdf5 = run_hdf5_gzip(v, 9, tmp, min_seconds);
        m.zfp_rev = run_zfp_reversible(v, min_seconds);
        m.zfp_fine = run_zfp_accuracy(v, 0.001 * m.range, min_seconds);
        m.zfp_coarse = run_zfp_accuracy(v, 0.01 * m.range, min_seconds);
        m.tlod = run_tlod(v, tmp, min_seconds);
        m.fast = run_tlod_fast(v, tmp, min_seconds);
        // Lossy .tlod (format 3.1) at the zfp columns' bounds; a constant volume stays lossless.
        if (m.range > 0) {
            m.lossy_fine = run_tlod_lossy(v, 0.001 * m.range, tmp, min_seconds);
            m.lossy_coarse = run_tlod_lossy(v, 0.01 * m.range, tmp, min_seconds);
        } else {
            m.lossy_fine = m.lossy_coarse = m.tlod;
        }
        if (!m.tlod.exact || !m.fast.exact) {
            std::fprintf(stderr, "%s: .tlod round trip FAILED\n", row.name.c_str());
            return 1;
        }
        ms.push_back(std::move(m));
        std::fprintf(stderr, "measured %s\n", row.name.c_str());
    }

    std::printf("Sizes in bytes (zfp at 0.1%% and 1%% of the value range, absolute bound; \"!\": not bit-exact "
                "or beyond the bound)\n");
    std::printf("%-36s %9s %9s %9s %9s %9s %9s %9s %9s %6s %6s %6s\n", "volume", "raw", "zstd19L", "h5gz9shuf",
                "zfp-rev", "zfp-0.1%", "zfp-1%", "tlod", "tlod/zst", "field%", "error%", "other%");
    for (const auto& m : ms) {
        const double t = double(m.tlod.bytes);
        std::printf("%-36s %9llu %9s %9s %9s %9s %9s %9llu %9.3f %6.1f %6.1f %6.1f\n", m.name.c_str(),
                    (unsigned long long)m.raw, size_cell(m.zstd, true).c_str(), size_cell(m.hdf5, true).c_str(),
                    size_cell(m.zfp_rev, true).c_str(), size_cell(m.zfp_fine, false, 0.001 * m.range).c_str(),
                    size_cell(m.zfp_coarse, false, 0.01 * m.range).c_str(), (unsigned long long)m.tlod.bytes,
                    t / double(m.zstd.bytes), 100 * double(m.tlod.field_bytes) / t,
                    100 * double(m.tlod.error_bytes) / t, 100 * double(m.tlod.other_bytes) / t);
    }
    std::printf("\nSection table (format 3.2, spec 4.4): the lossless .tlod with the full table (48 B a section,\n"
                "what --table full writes) and with the compact one (the default), against zstd-19; the compact\n"
                "table's bytes, and what a 4-byte checksum per non-empty section would have saved\n");
    std::printf("%-36s %9s %10s %10s %8s %8s %9s %9s %9s\n", "volume", "zstd19L", "tlod-full", "tlod", "full/zst",
                "tlod/zst", "tbl-full", "tbl", "-4B/sum");
    for (const auto& m : ms) {
        const uint64_t full = m.tlod.bytes - m.tlod.table_bytes + m.tlod.full_table_bytes;
        const double z = double(m.zstd.bytes);
        std::printf("%-36s %9llu %10llu %10llu %8.3f %8.3f %9llu %9llu %9llu\n", m.name.c_str(),
                    (unsigned long long)m.zstd.bytes, (unsigned long long)full, (unsigned long long)m.tlod.bytes,
                    double(full) / z, double(m.tlod.bytes) / z, (unsigned long long)m.tlod.full_table_bytes,
                    (unsigned long long)m.tlod.table_bytes, (unsigned long long)(4 * m.tlod.nonempty_sections));
    }
    std::printf("\nLossy .tlod (convert --max-error: the LOSSY feature of format 3.1, with the 3.2 compact table) at 0.1%% and 1%% of the value range: bytes and\n"
                "ratio to the lossless .tlod and to zstd-19 (\"!\": a sample beyond the bound)\n");
    std::printf("%-36s %9s %12s %8s %8s %12s %8s %8s\n", "volume", "tlod", "lossy-0.1%", "/tlod", "/zst",
                "lossy-1%", "/tlod", "/zst");
    for (const auto& m : ms) {
        const double t = double(m.tlod.bytes), z = double(m.zstd.bytes);
        std::printf("%-36s %9llu %12s %8.3f %8.3f %12s %8.3f %8.3f\n", m.name.c_str(), (unsigned long long)m.tlod.bytes,
                    size_cell(m.lossy_fine, false, 0.001 * m.range).c_str(), double(m.lossy_fine.bytes) / t,
                    double(m.lossy_fine.bytes) / z, size_cell(m.lossy_coarse, false, 0.01 * m.range).c_str(),
                    double(m.lossy_coarse.bytes) / t, double(m.lossy_coarse.bytes) / z);
    }
    std::printf("\nEncode/decode MB/s of raw samples (%s)\n",
                quick ? "one call each" : "each repeated for at least 0.2 s");
    std::printf("%-36s %11s %11s %11s %11s %11s %11s\n", "volume", "zstd19L", "h5gz9shuf", "zfp-rev", "zfp-0.1%",
                "zfp-1%", "tlod");
    for (const auto& m : ms)
        std::printf("%-36s %11s %11s %11s %11s %11s %11s\n", m.name.c_str(), speed_cell(m.zstd).c_str(),
                    speed_cell(m.hdf5).c_str(), speed_cell(m.zfp_rev).c_str(), speed_cell(m.zfp_fine).c_str(),
                    speed_cell(m.zfp_coarse).c_str(), speed_cell(m.tlod).c_str());
    std::printf("\nFast decoding (convert --fast-decode: static-table chunks, format 3.7): bytes against the\n"
                "default .tlod and zstd-19, encode/decode MB/s of both\n");
    std::printf("%-36s %9s %9s %8s %8s %11s %11s\n", "volume", "tlod", "fast", "/tlod", "/zst", "tlod", "fast");
    for (const auto& m : ms)
        std::printf("%-36s %9llu %9s %8.3f %8.3f %11s %11s\n", m.name.c_str(), (unsigned long long)m.tlod.bytes,
                    size_cell(m.fast, true).c_str(), double(m.fast.bytes) / double(m.tlod.bytes),
                    double(m.fast.bytes) / double(m.zstd.bytes), speed_cell(m.tlod).c_str(),
                    speed_cell(m.fast).c_str());
    int above = 0;
    for (const auto& m : ms) above += m.tlod.bytes > m.zstd.bytes;
    std::printf("\n.tlod larger than zstd -19 --long=27 on %d of %zu volumes\n", above, ms.size());
    if (quick) return 0;

    // A 257^3 16-bit sample: smooth blobs plus noise.
    const int N = 257;
    Volume v = Volume::allocate(Dims{N, N, N}, ValueType::U16);
    uint16_t* p = v.as<uint16_t>();
    uint32_t seed = 1;
    for (int zz = 0; zz < N; ++zz)
        for (int yy = 0; yy < N; ++yy)
            for (int xx = 0; xx < N; ++xx) {
                seed = seed * 1664525u + 1013904223u;
                double f = 1000 * std::sin(xx * 0.05) * std::cos(yy * 0.07) + 800 * std::sin(zz * 0.03 + xx * 0.01);
                p[(int64_t(zz) * N + yy) * N + xx] = uint16_t(std::lround(2000 + f) + (seed >> 29));
            }
    auto t0 = Clock::now();
    HtModel model = HtModel::build(v);
    const double build_s = secs(t0);
    t0 = Clock::now();
    const std::string path = (std::filesystem::temp_directory_path() / "bench_container_257.tlod").string();
    write_ht_container(path, model, tlod::metadata_for_volume(v));
    const double enc_s = secs(t0);
    const double size = double(std::filesystem::file_size(path));
    std::printf("\n257^3 u16 sample: build %.2f s, encode %.2f s, %.0f bytes (%.3f B/pt)\n", build_s,
                enc_s, size, size / (double(N) * N * N));
    struct Q { const char* name; HtDecodeRequest req; };
    std::vector<Q> qs;
    for (int c : {6, 4, 3, 2}) {
        HtDecodeRequest r;
        r.finest_cycle = c;
        qs.push_back({nullptr, r});
    }
    HtDecodeRequest box;
    box.box = std::array<int64_t, 6>{100, 100, 100, 115, 115, 115};
    qs.push_back({"box 16^3 @ full res", box});
    qs.push_back({"full decode", HtDecodeRequest{}});
    for (auto& q : qs) {
        t0 = Clock::now();
        auto r = tlod::ContainerReader::open(path);
        auto d = decode_ht(*r, q.req);
        const double t = secs(t0);
        char label[64];
        if (q.name) std::snprintf(label, sizeof label, "%s", q.name);
        else std::snprintf(label, sizeof label, "coarse LOD: cycles >= %d (levels <= %d)",
                           q.req.finest_cycle, 3 * (8 - 1 - q.req.finest_cycle) + 2);
        std::printf("  %-40s %8.3f ms  %10llu bytes read (%5.2f%% of file), %llu chunks\n", label,
                    t * 1e3, (unsigned long long)r->bytes_read(), 100.0 * double(r->bytes_read()) / size,
                    (unsigned long long)(d ? d->chunks_decoded : 0));
    }
    std::filesystem::remove(path);
    return 0;
}
