// Container size and speed, per real dataset (directory: argument, else $TETLOD_DATA_DIR, else shared/data beside the checkout), against (same run):
// the raw field, zstd -19 of the raw field, and the paper's 14 bytes per point.
// Then decode throughput against plain zstd decompression of the same bytes,
// and the bytes read for a coarse LOD and a small full-resolution box on a 257^3
// sample. Usage: bench_container [DATA_DIR] [--quick]
#include <zstd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

using namespace tetlod;
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

int main(int argc, char** argv) {
    std::string dir = std::getenv("TETLOD_DATA_DIR") ? std::getenv("TETLOD_DATA_DIR") : TETLOD_DEFAULT_DATA_DIR;
    bool quick = false;
    for (int i = 1; i < argc; ++i) {
        if (std::string(argv[i]) == "--quick") quick = true;
        else dir = argv[i];
    }
    std::printf("%-40s %9s %9s %9s %9s %8s %8s %8s %7s %9s %9s\n", "dataset", "points", "raw B/pt",
                "zstd19", "tlod", "field", "errors", "paper", "<zstd?", "dec MB/s", "zstd MB/s");
    std::vector<std::filesystem::path> files;
    if (std::filesystem::is_directory(dir))
        for (auto& e : std::filesystem::directory_iterator(dir))
            if (e.path().extension() == ".raw") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& p : files) {
        Volume v;
        if (!load_raw(p, v)) continue;
        const double n = double(v.count());
        // zstd -19 of the raw field, and its decompression speed.
        std::vector<char> z(ZSTD_compressBound(v.data.size()));
        const std::size_t zn = ZSTD_compress(z.data(), z.size(), v.data.data(), v.data.size(), 19);
        std::vector<std::byte> back(v.data.size());
        auto t0 = Clock::now();
        int reps = 0;
        do {
            ZSTD_decompress(back.data(), back.size(), z.data(), zn);
            ++reps;
        } while (secs(t0) < 0.3);
        const double zstd_mbs = double(v.data.size()) * reps / secs(t0) / 1e6;

        tlod::Metadata meta = tlod::metadata_for_volume(v);
        HtModel model = HtModel::build(v);
        tlod::ContainerWriter w;
        encode_ht(model, meta, w);
        auto file = w.finish();
        uint64_t field = 0, errs = 0;
        auto r = tlod::ContainerReader::from_memory(file);
        for (const auto& s : r->sections()) {
            if (s.type == tlod::kSectionHtField) field += s.stored_size;
            if (s.type == tlod::kSectionHtErrors) errs += s.stored_size;
        }
        t0 = Clock::now();
        reps = 0;
        do {
            auto rr = tlod::ContainerReader::from_memory(file);
            auto d = decode_volume(*rr);
            if (!d || d->data != v.data) {
                std::fprintf(stderr, "%s: round trip FAILED\n", p.filename().c_str());
                return 1;
            }
            ++reps;
        } while (secs(t0) < 0.3);
        const double dec_mbs = double(v.data.size()) * reps / secs(t0) / 1e6;
        std::printf("%-40s %9.0f %9.3f %9.3f %9.3f %8.3f %8.3f %8.1f %7s %9.0f %9.0f\n",
                    p.filename().c_str(), n, double(v.data.size()) / n, double(zn) / n,
                    double(file.size()) / n, double(field) / n, double(errs) / n, 14.0,
                    file.size() < zn ? "yes" : "no", dec_mbs, zstd_mbs);
    }
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
