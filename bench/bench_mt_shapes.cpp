// bench_mt_shapes: what a shape cap on the MT build (MtBuildOptions::max_shape_ratio,
// `--max-shape-ratio`) costs and buys, on the real datasets (directory: argument, else
// $TETLOD_DATA_DIR, else shared/data beside the checkout). For each volume and cap, the
// MT is built and uniform LODs at 0.1, 0.3, 1, 3 and 10 % of the value range are
// extracted; each prints its tets, the tets relative to the uncapped build (the first
// cap listed), and the mean and worst circumradius / shortest edge ratio (physical
// coordinates; regular tet 0.61) measured by the analysis library on the output mesh.
//
// Usage: bench_mt_shapes [DATA_DIR] [--caps 0,10,5,3] [--only NAME] [--big] [--threads T]
//   --caps: the caps to compare, 0 = no cap (put it first: it is the reference);
//   --big adds bucky 128^3 (minutes per cap).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tetlod/analysis/shape_quality.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/models/mt/mt_model.hpp"

using namespace tetlod;

namespace {

struct Dataset {
    const char* file;
    Dims dims;
    ValueType type;
    Vec3 spacing;
    bool big;
};

const std::vector<Dataset> kDatasets = {
    {"bucky_32x32x32_uint8.raw", {32, 32, 32}, ValueType::U8, {1, 1, 1}, false},
    {"head_mr_48x62x42_uint8.raw", {48, 62, 42}, ValueType::U8, {4, 4, 4}, false},
    {"neghip_64x64x64_uint8.raw", {64, 64, 64}, ValueType::U8, {1, 1, 1}, false},
    {"iron_protein_68x68x68_uint8.raw", {68, 68, 68}, ValueType::U8, {1, 1, 1}, false},
    {"headsq_64x64x93_int16.raw", {64, 64, 93}, ValueType::I16, {3.2, 3.2, 1.5}, false},
    {"m4_total_density_25x22x31_float32.raw", {25, 22, 31}, ValueType::F32, {1, 1, 1}, false},
    {"bucky_128x128x128_uint8.raw", {128, 128, 128}, ValueType::U8, {1, 1, 1}, true},
};
const double kLevels[] = {0.001, 0.003, 0.01, 0.03, 0.1};

bool read_raw(const std::string& path, Volume& v) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    f.read(reinterpret_cast<char*>(v.data.data()), std::streamsize(v.data.size()));
    return bool(f);
}

std::vector<double> parse_list(const std::string& s) {
    std::vector<double> out;
    std::stringstream in(s);
    for (std::string item; std::getline(in, item, ',');) out.push_back(std::atof(item.c_str()));
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    std::string dir, only;
    const char* env = std::getenv("TETLOD_DATA_DIR");
    dir = env ? env : TETLOD_DEFAULT_DATA_DIR;
    std::vector<double> caps = {0, 10, 5, 3};
    bool big = false;
    int threads = 0;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--caps" && i + 1 < argc) caps = parse_list(argv[++i]);
        else if (a == "--only" && i + 1 < argc) only = argv[++i];
        else if (a == "--big") big = true;
        else if (a == "--threads" && i + 1 < argc) threads = std::atoi(argv[++i]);
        else if (a.rfind("--", 0) == 0) {
            std::fprintf(stderr, "bench_mt_shapes: unknown option %s\n", a.c_str());
            return 2;
        } else dir = a;
    }
    std::printf("MT shape cap trade-off: per uniform LOD (%% of range), tets (x uncapped) mean / worst ratio\n");
    std::printf("%-14s %5s %7s", "dataset", "cap", "build_s");
    for (double l : kLevels) std::printf(" | %-30.1f", l * 100);
    std::printf("\n");
    for (const Dataset& d : kDatasets) {
        if (d.big && !big) continue;
        if (!only.empty() && std::string(d.file).find(only) == std::string::npos) continue;
        Volume v = Volume::allocate(d.dims, d.type);
        v.spacing = d.spacing;
        if (!read_raw(dir + "/" + d.file, v)) {
            std::printf("%-14s skipped: cannot read %s/%s\n", d.file, dir.c_str(), d.file);
            continue;
        }
        const auto range = v.range();
        const double span = range[1] - range[0];
        const std::string name = std::string(d.file).substr(0, std::string(d.file).find('_', 5));
        std::vector<size_t> reference;
        for (double cap : caps) {
            MtBuildOptions o;
            o.max_shape_ratio = cap;
            o.threads = threads;
            const auto t0 = std::chrono::steady_clock::now();
            const MtModel mt = MtModel::build(v, o);
            const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::printf("%-14s %5g %7.2f", name.c_str(), cap, build_s);
            const bool first = reference.empty();
            for (size_t k = 0; k < std::size(kLevels); ++k) {
                LodQuery q;
                q.error_in = kLevels[k] * span;
                const TetMesh m = mt.extract(q);
                const ShapeQualityStats s = shape_quality(m);
                if (first) reference.push_back(m.tet_count());
                std::printf(" | %8zu (%5.3f) %5.2f / %6.1f", m.tet_count(),
                            double(m.tet_count()) / double(reference[k]), s.mean, s.max);
            }
            std::printf("\n");
            std::fflush(stdout);
        }
    }
    return 0;
}
