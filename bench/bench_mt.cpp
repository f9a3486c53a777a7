// bench_mt: the edge-based Multi-Tessellation on the real datasets (directory: argument, else $TETLOD_DATA_DIR, else shared/data beside the checkout).
// Prints, per dataset: build time and peak memory (getrusage), updates, base mesh,
// encoded size (bytes per grid point), tets at the same uniform errors for HT and MT,
// tets in a box and an isovalue query, average tets added per split, and the shape
// quality (circumradius / shortest edge, physical coordinates) of MT meshes.
//
// Usage: bench_mt [DATA_DIR] [--only NAME] [--big] [--no-ht] [--shape-cap R] [--threads T]
//                 [--brick-cells B] [--build-only]
//   --big adds bucky 128^3; --shape-cap refuses collapses creating tets with ratio > R;
//   --threads / --brick-cells set MtBuildOptions (0 = TBB default / one brick);
//   --build-only skips the queries. Peak MB is the process's (run one dataset with --only).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/core/volume.hpp"

using namespace tetlod;

namespace {

struct Dataset {
    const char* file;
    Dims dims;
    ValueType type;
    bool big;
};

double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double peak_mb() {
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss / 1024.0;
}

bool read_raw(const std::string& path, Volume& v) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    f.read(reinterpret_cast<char*>(v.data.data()), std::streamsize(v.data.size()));
    return bool(f);
}

double shape_ratio(const TetMesh& m, size_t i) {
    std::array<std::array<double, 3>, 4> p;
    for (int k = 0; k < 4; ++k) p[k] = m.geometry.world(m.points[m.tets[i][k]]);
    auto sub = [](auto a, auto b) { return std::array<double, 3>{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
    auto dot = [](auto a, auto b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    auto cr = [](auto a, auto b) {
        return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    const auto a = sub(p[1], p[0]), b = sub(p[2], p[0]), c = sub(p[3], p[0]);
    const auto bc = cr(b, c), ca = cr(c, a), ab = cr(a, b);
    const double den = 2 * dot(a, bc);
    std::array<double, 3> o;
    for (int k = 0; k < 3; ++k) o[k] = (dot(a, a) * bc[k] + dot(b, b) * ca[k] + dot(c, c) * ab[k]) / den;
    double sh = std::min({dot(a, a), dot(b, b), dot(c, c), dot(sub(p[2], p[1]), sub(p[2], p[1])),
                          dot(sub(p[3], p[1]), sub(p[3], p[1])), dot(sub(p[3], p[2]), sub(p[3], p[2]))});
    return std::sqrt(dot(o, o) / sh);
}
double mean_ratio(const TetMesh& m) {
    double s = 0;
    for (size_t i = 0; i < m.tet_count(); ++i) s += shape_ratio(m, i);
    return m.tet_count() ? s / double(m.tet_count()) : 0;
}

}  // namespace

int main(int argc, char** argv) {
    std::string dir = std::getenv("TETLOD_DATA_DIR") ? std::getenv("TETLOD_DATA_DIR") : TETLOD_DEFAULT_DATA_DIR, only;
    bool big = false, no_ht = false, build_only = false;
    MtBuildOptions bopt;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--only" && i + 1 < argc) only = argv[++i];
        else if (a == "--big") big = true;
        else if (a == "--no-ht") no_ht = true;
        else if (a == "--build-only") build_only = true;
        else if (a == "--threads" && i + 1 < argc) bopt.threads = std::atoi(argv[++i]);
        else if (a == "--brick-cells" && i + 1 < argc) bopt.brick_cells = std::atoi(argv[++i]);
        else if (a == "--shape-cap" && i + 1 < argc) bopt.max_shape_ratio = std::atof(argv[++i]);
        else dir = a;
    }
    const std::vector<Dataset> sets = {
        {"bucky_32x32x32_uint8.raw", {32, 32, 32}, ValueType::U8, false},
        {"head_mr_48x62x42_uint8.raw", {48, 62, 42}, ValueType::U8, false},
        {"neghip_64x64x64_uint8.raw", {64, 64, 64}, ValueType::U8, false},
        {"iron_protein_68x68x68_uint8.raw", {68, 68, 68}, ValueType::U8, false},
        {"headsq_64x64x93_int16.raw", {64, 64, 93}, ValueType::I16, false},
        {"m4_total_density_25x22x31_float32.raw", {25, 22, 31}, ValueType::F32, false},
        {"bucky_128x128x128_uint8.raw", {128, 128, 128}, ValueType::U8, true},
    };
    std::printf("%-36s %8s %8s %8s %8s %9s %7s %7s %6s\n", "dataset", "build_s", "pts/s", "peak_MB", "updates",
                "base_tets", "B/pt", "B/pt+f", "ins/sp");
    for (const Dataset& d : sets) {
        if (d.big && !big) continue;
        if (!only.empty() && std::string(d.file).find(only) == std::string::npos) continue;
        Volume v = Volume::allocate(d.dims, d.type);
        if (!read_raw(dir + "/" + d.file, v)) {
            std::printf("%-36s missing\n", d.file);
            continue;
        }
        const double t0 = now();
        const MtModel mt = MtModel::build(v, bopt);
        const double build_s = now() - t0;
        const double peak = peak_mb();
        const double n = double(v.count());
        const auto enc = encode_mt(mt);
        MtEncodeOptions with_field;
        with_field.include_field = true;
        const auto encf = encode_mt(mt, with_field);
        LodQuery full;
        full.full = true;
        MtExtractStats fs;
        mt.extract(full, &fs);
        const double ins = fs.splits ? double(fs.tets_inserted - fs.tets_removed) / double(fs.splits) : 0;
        std::printf("%-36s %8.2f %8.0f %8.0f %8zu %9zu %7.2f %7.2f %6.2f   (removed %.1f, inserted %.1f per split)\n",
                    d.file, build_s, n / build_s, peak, mt.updates().size(), mt.base_tets().size(), enc.size() / n,
                    encf.size() / n, ins, double(fs.tets_removed) / double(fs.splits),
                    double(fs.tets_inserted) / double(fs.splits));
        std::fflush(stdout);
        if (build_only) continue;
        const auto r = v.range();
        const double span = r[1] - r[0];
        std::unique_ptr<HtModel> ht;
        if (!no_ht) ht = std::make_unique<HtModel>(HtModel::build(v));
        std::printf("    %-28s %10s %10s %7s %9s\n", "query", "HT_tets", "MT_tets", "MT/HT", "MT_ratio");
        auto row = [&](const std::string& name, const LodQuery& q) {
            const TetMesh m = mt.extract(q);
            const size_t h = ht ? ht->extract(q).tet_count() : 0;
            std::printf("    %-28s %10zu %10zu %7.3f %9.3f\n", name.c_str(), h, m.tet_count(),
                        h ? double(m.tet_count()) / double(h) : 0.0, mean_ratio(m));
        };
        for (double f : {0.0, 0.01, 0.03, 0.1}) {
            LodQuery q;
            q.error_in = f * span;
            char name[64];
            std::snprintf(name, sizeof name, "uniform %.0f%% (%.3g)", f * 100, q.error_in);
            row(name, q);
        }
        const Dims& D = v.dims;
        LodQuery box;
        box.error_in = 0.0, box.error_out = 0.1 * span;
        box.box = std::array<int64_t, 6>{D.x / 4, D.y / 4, D.z / 4, D.x / 2, D.y / 2, D.z / 2};
        row("box 0 / 10%", box);
        LodQuery iso;
        iso.error_in = 0.0, iso.error_out = 0.1 * span;
        iso.isovalues = {r[0] + 0.4 * span};
        row("iso 40% 0 / 10%", iso);
        std::fflush(stdout);
    }
    return 0;
}
