// Decode throughput of the .tlod HT codec, in CPU time on one thread (the
// machine is shared, wall time lies): the 257^3 u16 sample of bench_container
// (or a raw file given as NAME_XxYxZ_type.raw), full decode with and without
// the error bounds, in MB/s of raw output, plus wall time. With --threads N
// (0: TBB's default) chunks of a cycle decode in parallel and wall time is the
// figure to read. --field-only skips the field+errors run (what `tetlod decode`
// does is the field only); --brick-log2 G codes bricks of 2^(t+1+G) (default 4);
// --fast-decode codes the field as `convert --fast-decode` (static-table rANS).
// Usage: bench_decode [RAW] [--reps N] [--threads N] [--field-only] [--brick-log2 G] [--fast-decode]
#include <tbb/global_control.h>

#include <chrono>
#include <memory>

#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <regex>
#include <string>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

using namespace tetlod;

static double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

static Volume sample_257() {
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
    return v;
}

int main(int argc, char** argv) {
    std::string raw;
    int reps = 1, threads = 1, brick_log2 = 4;
    bool field_only = false, fast_decode = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--reps" && i + 1 < argc) reps = std::atoi(argv[++i]);
        else if (a == "--threads" && i + 1 < argc) threads = std::atoi(argv[++i]);
        else if (a == "--field-only") field_only = true;
        else if (a == "--fast-decode") fast_decode = true;
        else if (a == "--brick-log2" && i + 1 < argc) brick_log2 = std::atoi(argv[++i]);
        else raw = a;
    }
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0)
        limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    Volume v;
    if (raw.empty()) {
        v = sample_257();
    } else {
        static const std::regex re(R"(.*_(\d+)x(\d+)x(\d+)_([a-z0-9]+)\.raw)");
        std::smatch m;
        if (!std::regex_match(raw, m, re)) return 2;
        v = Volume::allocate(Dims{std::stoll(m[1]), std::stoll(m[2]), std::stoll(m[3])}, *parse_value_type(m[4].str()));
        std::ifstream in(raw, std::ios::binary);
        in.read(reinterpret_cast<char*>(v.data.data()), std::streamsize(v.data.size()));
    }
    HtModel model = HtModel::build(v);
    tlod::ContainerWriter w;
    HtEncodeOptions eo;
    eo.brick_log2 = brick_log2;
    eo.fast_decode = fast_decode;
    encode_ht(model, tlod::metadata_for_volume(v), w, eo);
    const auto file = w.finish();
    const double mb = double(v.data.size()) / 1e6;
    for (bool errors : {false, true}) {
        if (errors && field_only) break;
        const double t0 = cpu_seconds();
        const auto w0 = std::chrono::steady_clock::now();
        for (int r = 0; r < reps; ++r) {
            auto rr = tlod::ContainerReader::from_memory(file);
            HtDecodeRequest req;
            req.errors = errors;
            auto d = decode_ht(*rr, req);
            if (!d) {
                std::fprintf(stderr, "decode failed: %s\n", d.failure().message.c_str());
                return 1;
            }
        }
        const double t = (cpu_seconds() - t0) / reps;
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count() / reps;
        std::printf("%-28s %8.3f s CPU %7.1f MB/s | %7.3f s wall %7.1f MB/s (%zu bytes stored, %.3f B/pt)\n",
                    errors ? "full decode, field+errors" : "full decode, field only", t, mb / t, wall,
                    mb / wall, file.size(), double(file.size()) / double(v.count()));
    }
    return 0;
}
