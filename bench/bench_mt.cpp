// bench_mt: the edge-based Multi-Tessellation on the real datasets (directory: argument, else $TETLOD_DATA_DIR, else shared/data beside the checkout).
// Prints, per dataset: build time, points/s, peak memory of the build, the model's
// in-memory size (MtModel::memory_bytes) and encoded size (bytes per grid point),
// updates, base mesh; then tets at the same uniform errors for HT and MT, tets in a
// box and an isovalue query, and the shape quality (circumradius / shortest edge,
// physical coordinates) of MT meshes; then the VTK peer: VTK's tetrahedral quadric
// decimation (vtkUnstructuredGridQuadricDecimation) of the full mesh at the tet counts
// of the MT's meshes at 1% and 10% of the range, both meshes measured by one evaluator
// independent of tetlod (peer_vtk_decimation.py: error at every grid point, points
// not covered).
//
// Usage: bench_mt [DATA_DIR] [--only NAME] [--big] [--no-ht] [--no-vtk] [--shape-cap R]
//                 [--threads T] [--brick-cells B] [--pass-cap F] [--build-only] [--generated N]
//                 [--full | --no-full]
//   --big adds bucky 128^3 (with its VTK peer); --no-vtk skips the peer (it runs on
//   bucky 32^3, head_mr, neghip, and bucky 128^3 with --big); --shape-cap refuses
//   collapses creating tets with ratio > R; --threads / --brick-cells set
//   MtBuildOptions (0 = TBB default / one brick); --build-only skips the queries (not
//   the peer); --generated N adds the "multiscale" sample volume at N^3 u8 (e.g. 257;
//   long: no VTK peer); ins/sp needs the full-resolution mesh (about 220 B per grid point
//   and minutes at 257^3), so it is measured up to 4 M points unless --full asks for it
//   (--no-full: never).
// Columns: peak_MB is the process's resident high-water mark during the build (reset
// before each build through /proc/self/clear_refs, so it includes the libraries and
// the volume); buildB/pt is that peak minus the resident size just before the build,
// per grid point (what the build itself takes); memB/pt is MtModel::memory_bytes()
// per grid point; B/pt and B/pt+f the encoded MT without and with its field.
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/converters/sample_volumes.hpp"
#include "tetlod/core/volume.hpp"

using namespace tetlod;

namespace {

struct Dataset {
    const char* file;
    Dims dims;
    ValueType type;
    bool big;
    bool vtk;  // with the VTK peer
};

double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Starts a new resident high-water mark (Linux: "5" to clear_refs resets VmHWM).
/// False when the kernel refuses: peak_mb() is then the whole process's.
bool reset_peak() {
    std::ofstream f("/proc/self/clear_refs");
    return bool(f << "5");
}
/// A line of /proc/self/status ("VmHWM:", "VmRSS:") in MB; -1 when absent.
double status_mb(const char* key) {
    std::ifstream f("/proc/self/status");
    for (std::string line; std::getline(f, line);)
        if (line.rfind(key, 0) == 0) return std::atof(line.c_str() + std::strlen(key)) / 1024.0;  // kB
    return -1;
}
double peak_mb() {
    const double hwm = status_mb("VmHWM:");
    if (hwm >= 0) return hwm;
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

const char* dtype_name(ValueType t) {
    switch (t) {
        case ValueType::U8: return "u8";
        case ValueType::I16: return "i16";
        case ValueType::U16: return "u16";
        case ValueType::F32: return "f32";
        default: return nullptr;
    }
}

/// The mesh for peer_vtk_decimation.py (format in its docstring).
void write_peer_mesh(const TetMesh& m, const std::string& path) {
    std::ofstream f(path, std::ios::binary);
    const int64_t counts[2] = {int64_t(m.points.size()), int64_t(m.tets.size())};
    f.write(reinterpret_cast<const char*>(counts), sizeof counts);
    for (const auto& p : m.points) {
        const double xyz[3] = {double(p[0]), double(p[1]), double(p[2])};
        f.write(reinterpret_cast<const char*>(xyz), sizeof xyz);
    }
    f.write(reinterpret_cast<const char*>(m.values.data()), std::streamsize(m.values.size() * sizeof(double)));
    for (const auto& t : m.tets) {
        const int32_t ids[4] = {int32_t(t[0]), int32_t(t[1]), int32_t(t[2]), int32_t(t[3])};
        f.write(reinterpret_cast<const char*>(ids), sizeof ids);
    }
}

/// VTK's decimation at the tet counts of the MT's meshes at 1% and 10% of the range,
/// both measured by the script (errors at every grid point, points not covered).
void vtk_peer(const MtModel& mt, const std::string& raw_path, const Dims& d, ValueType type) {
    const char* dt = dtype_name(type);
    if (!dt) {
        std::printf("    VTK peer: skipped (no numpy dtype for this value type)\n");
        return;
    }
    const auto r = mt.value_range();
    const std::string tmp = std::filesystem::temp_directory_path() / ("bench_mt_" + std::to_string(::getpid()));
    std::filesystem::create_directories(tmp);
    std::string cmd = "/usr/bin/python3 " TETLOD_BENCH_DIR "/peer_vtk_decimation.py '" + raw_path + "' " +
                      std::to_string(d.x) + " " + std::to_string(d.y) + " " + std::to_string(d.z) + " " + dt;
    std::printf("    VTK peer (uniform 1%%, then 10%% of the range; MT time: its extraction):\n");
    for (double f : {0.01, 0.1}) {
        LodQuery q;
        q.error_in = f * (r[1] - r[0]);
        const double t0 = now();
        const TetMesh m = mt.extract(q);
        std::printf("    MT uniform %.0f%% (bound %.4g): %zu tets, extracted in %.3f s\n", f * 100, q.error_in,
                    m.tet_count(), now() - t0);
        const std::string path = tmp + "/mt_" + std::to_string(int(f * 100)) + ".bin";
        write_peer_mesh(m, path);
        cmd += " " + path;
    }
    std::fflush(stdout);
    FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
    if (!p) {
        std::printf("    VTK peer: skipped (cannot run /usr/bin/python3)\n");
    } else {
        char line[512];
        while (std::fgets(line, sizeof line, p)) std::printf("      %s", line);
        if (::pclose(p) != 0) std::printf("    VTK peer: the script failed (see above)\n");
    }
    std::fflush(stdout);
    std::filesystem::remove_all(tmp);
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
    bool big = false, no_ht = false, build_only = false, no_vtk = false;
    int64_t generated = 0;
    enum class FullMesh { Auto, Always, Never } full_mesh = FullMesh::Auto;
    constexpr double kFullMeshPoints = 4e6;  // Auto: the ins/sp column up to this many points
    MtBuildOptions bopt;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--only" && i + 1 < argc) only = argv[++i];
        else if (a == "--big") big = true;
        else if (a == "--no-ht") no_ht = true;
        else if (a == "--no-vtk") no_vtk = true;
        else if (a == "--build-only") build_only = true;
        else if (a == "--full") full_mesh = FullMesh::Always;
        else if (a == "--no-full") full_mesh = FullMesh::Never;
        else if (a == "--generated" && i + 1 < argc) generated = std::atoll(argv[++i]);
        else if (a == "--threads" && i + 1 < argc) bopt.threads = std::atoi(argv[++i]);
        else if (a == "--brick-cells" && i + 1 < argc) bopt.brick_cells = std::atoi(argv[++i]);
        else if (a == "--pass-cap" && i + 1 < argc) bopt.pass_error_cap = std::atof(argv[++i]);
        else if (a == "--shape-cap" && i + 1 < argc) bopt.max_shape_ratio = std::atof(argv[++i]);
        else dir = a;
    }
    const std::vector<Dataset> sets = {
        {"bucky_32x32x32_uint8.raw", {32, 32, 32}, ValueType::U8, false, true},
        {"head_mr_48x62x42_uint8.raw", {48, 62, 42}, ValueType::U8, false, true},
        {"neghip_64x64x64_uint8.raw", {64, 64, 64}, ValueType::U8, false, true},
        {"iron_protein_68x68x68_uint8.raw", {68, 68, 68}, ValueType::U8, false, false},
        {"headsq_64x64x93_int16.raw", {64, 64, 93}, ValueType::I16, false, false},
        {"m4_total_density_25x22x31_float32.raw", {25, 22, 31}, ValueType::F32, false, false},
        {"bucky_128x128x128_uint8.raw", {128, 128, 128}, ValueType::U8, true, true},
    };
    std::printf("%-36s %8s %8s %8s %9s %8s %8s %9s %7s %7s %6s\n", "dataset", "build_s", "pts/s", "peak_MB",
                "buildB/pt", "memB/pt", "updates", "base_tets", "B/pt", "B/pt+f", "ins/sp");
    // One dataset: the build row, then (unless --build-only) the queries, then the peer.
    auto run = [&](const std::string& name, const Volume& v, const std::string& raw_path, bool with_vtk) {
        // The build takes its volume by value, as `convert` hands over its own:
        // the copy is made here, outside the measured time and peak.
        Volume input = v;
        ::malloc_trim(0);  // heap freed by the previous dataset back to the system: `before` is honest
        reset_peak();
        const double before = std::max(0.0, status_mb("VmRSS:"));  // libraries, the volume
        const double t0 = now();
        const MtModel mt = MtModel::build(std::move(input), bopt);
        const double build_s = now() - t0;
        const double peak = peak_mb();
        const double n = double(v.count());
        const auto enc = encode_mt(mt);
        MtEncodeOptions with_field;
        with_field.include_field = true;
        const auto encf = encode_mt(mt, with_field);
        const bool measure_full =
            full_mesh == FullMesh::Always || (full_mesh == FullMesh::Auto && n <= kFullMeshPoints);
        char ins_sp[160] = "     -   (full mesh not extracted: --full)";
        if (measure_full) {
            LodQuery full;
            full.full = true;
            MtExtractStats fs;
            mt.extract(full, &fs);
            const double splits = fs.splits ? double(fs.splits) : 1.0;
            std::snprintf(ins_sp, sizeof ins_sp, "%6.2f   (removed %.1f, inserted %.1f per split)",
                          double(fs.tets_inserted - fs.tets_removed) / splits, double(fs.tets_removed) / splits,
                          double(fs.tets_inserted) / splits);
        }
        std::printf("%-36s %8.2f %8.0f %8.0f %9.1f %8.2f %8zu %9zu %7.2f %7.2f %s\n", name.c_str(), build_s,
                    n / build_s, peak, (peak - before) * 1048576.0 / n, double(mt.memory_bytes()) / n,
                    mt.updates().size(), mt.base_tets().size(), enc.size() / n, encf.size() / n, ins_sp);
        std::fflush(stdout);
        if (!build_only) {
            const auto r = v.range();
            const double span = r[1] - r[0];
            std::unique_ptr<HtModel> ht;
            if (!no_ht) ht = std::make_unique<HtModel>(HtModel::build(v));
            std::printf("    %-28s %10s %10s %7s %9s %8s %8s\n", "query", "HT_tets", "MT_tets", "MT/HT", "MT_ratio",
                        "MT_s", "MT_MB");
            // MT_s and MT_MB: the MT extraction's time and resident high-water mark above
            // the resident size before it (the query's working memory and its mesh).
            auto row = [&](const std::string& label, const LodQuery& q) {
                ::malloc_trim(0);
                reset_peak();
                const double rss0 = std::max(0.0, status_mb("VmRSS:"));
                const double t1 = now();
                const TetMesh m = mt.extract(q);
                const double mt_s = now() - t1;
                const double mt_mb = peak_mb() - rss0;
                const size_t h = ht ? ht->extract(q).tet_count() : 0;
                std::printf("    %-28s %10zu %10zu %7.3f %9.3f %8.3f %8.1f\n", label.c_str(), h, m.tet_count(),
                            h ? double(m.tet_count()) / double(h) : 0.0, mean_ratio(m), mt_s, mt_mb);
            };
            for (double f : {0.0, 0.01, 0.03, 0.1, 0.3}) {
                LodQuery q;
                q.error_in = f * span;
                char label[64];
                std::snprintf(label, sizeof label, "uniform %.0f%% (%.3g)", f * 100, q.error_in);
                row(label, q);
            }
            const Dims& D = v.dims;
            LodQuery box;
            box.error_in = 0.0, box.error_out = 0.1 * span;
            box.box = std::array<int64_t, 6>{D.x / 4, D.y / 4, D.z / 4, D.x / 2, D.y / 2, D.z / 2};
            row("box 0 / 10%", box);
            // A small region of interest on a coarse rest: the query touches little of the volume.
            LodQuery small;
            small.error_in = 0.0, small.error_out = span;
            small.box = std::array<int64_t, 6>{D.x / 2, D.y / 2, D.z / 2, D.x / 2 + D.x / 16, D.y / 2 + D.y / 16,
                                               D.z / 2 + D.z / 16};
            row("box 1/16 0 / 100%", small);
            LodQuery iso;
            iso.error_in = 0.0, iso.error_out = 0.1 * span;
            iso.isovalues = {r[0] + 0.4 * span};
            row("iso 40% 0 / 10%", iso);
            std::fflush(stdout);
        }
        if (with_vtk && !no_vtk && !raw_path.empty()) vtk_peer(mt, raw_path, v.dims, v.type);
    };
    for (const Dataset& d : sets) {
        if (d.big && !big) continue;
        if (!only.empty() && std::string(d.file).find(only) == std::string::npos) continue;
        Volume v = Volume::allocate(d.dims, d.type);
        if (!read_raw(dir + "/" + d.file, v)) {
            std::printf("%-36s missing\n", d.file);
            continue;
        }
        run(d.file, v, dir + "/" + d.file, d.vtk);
    }
    if (generated > 0) {
        const Dims g{generated, generated, generated};
        const Volume v = make_sample_volume("multiscale", g, ValueType::U8);
        run("multiscale " + std::to_string(generated) + "^3 u8 (generated)", v, "", false);
    }
    return 0;
}
