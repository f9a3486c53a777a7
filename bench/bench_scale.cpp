// Cost against volume size: conversion (plane by plane, at the default budget
// and at 512 MiB, beside the in-memory path, checking the bytes agree), and fixed queries extracted from the
// container, each in a fresh process so its peak RSS (wait4) is its own. The
// peer in the same run is the same query on the volume in memory (read the raw
// file, build the HT, extract), which costs in proportion to the volume by
// construction: a query from the container should not.
//
//   build/bench/bench_scale [--sizes 129,257,513] [--real FILE.raw X,Y,Z u8] [--dir DIR]
//                           [--full-max 257]
//
// Volumes are `tetlod sample multiscale` at each size (u8); --real adds one raw
// file. Files go to DIR (default: a folder in the working directory), which is
// removed at the end unless given.
//
// Last, `--full` to .vtu (zlib) on the volumes of at most --full-max points per
// axis: streamed from the container and from memory, beside VTK's
// tetrahedralization + XML write of the same volume (bench/peer_vtk_full_mesh.py
// with /usr/bin/python3, when its vtk module imports; u8 volumes), as tets/s.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "tetlod/tetlod.hpp"

using namespace tetlod;

namespace {

struct Input {
    std::string name, raw;
    Dims dims;
    ValueType type = ValueType::U8;
};

// The fixed queries, the same for every size: thresholds in % of the range,
// boxes and spheres around the centre.
struct QuerySpec {
    const char* name;
    LodQuery (*make)(const Dims&, const std::array<double, 2>&);
};

double pct(const std::array<double, 2>& r, double p) { return p * (r[1] - r[0]) / 100; }

const QuerySpec kQueries[] = {
    {"10% uniform",
     [](const Dims&, const std::array<double, 2>& r) {
         LodQuery q;
         q.error_in = pct(r, 10);
         return q;
     }},
    {"1% uniform",
     [](const Dims&, const std::array<double, 2>& r) {
         LodQuery q;
         q.error_in = pct(r, 1);
         return q;
     }},
    {"32^3 box, full res",
     [](const Dims& d, const std::array<double, 2>&) {
         LodQuery q;
         q.error_in = -1;
         const int64_t c[3] = {d.x / 2, d.y / 2, d.z / 2};
         q.box = std::array<int64_t, 6>{c[0] - 16, c[1] - 16, c[2] - 16, c[0] + 15, c[1] + 15, c[2] + 15};
         return q;
     }},
    {"isovalue 50%, 1%",
     [](const Dims&, const std::array<double, 2>& r) {
         LodQuery q;
         q.error_in = pct(r, 1);
         q.isovalues = {r[0] + pct(r, 50)};
         return q;
     }},
};

struct Child {
    int status = -1;
    double seconds = 0, peak_mb = 0;
    std::string out;  // what the child printed (one line)
};

// Runs this program with `args` in a fresh process; its stdout is captured.
Child run_child(const std::vector<std::string>& args) {
    int fds[2];
    if (pipe(fds) != 0) return {};
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = fork();
    if (pid == 0) {
        dup2(fds[1], STDOUT_FILENO);
        close(fds[0]);
        std::vector<char*> argv{const_cast<char*>("bench_scale")};
        for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
        argv.push_back(nullptr);
        execv("/proc/self/exe", argv.data());
        _exit(127);
    }
    close(fds[1]);
    Child c;
    char buf[4096];
    for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) c.out.append(buf, std::size_t(n));
    close(fds[0]);
    int st = 0;
    rusage ru{};
    wait4(pid, &st, 0, &ru);
    c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    c.status = WIFEXITED(st) ? WEXITSTATUS(st) : -WTERMSIG(st);
    c.peak_mb = double(ru.ru_maxrss) / 1024.0;
    if (!c.out.empty() && c.out.back() == '\n') c.out.pop_back();
    return c;
}

VolumeReadOptions raw_options(const Dims& d, ValueType t) {
    VolumeReadOptions o;
    o.dims = d;
    o.type = t;
    return o;
}

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

Dims parse_dims(const std::string& s) {
    Dims d;
    std::sscanf(s.c_str(), "%lld,%lld,%lld", reinterpret_cast<long long*>(&d.x), reinterpret_cast<long long*>(&d.y),
                reinterpret_cast<long long*>(&d.z));
    return d;
}

// ---- children ----

// mode: "planes" (read plane by plane, default budget), "planes512" (512 MiB
// budget), "memory" (the whole volume read, then the in-memory HT: the peer).
int child_convert(const std::string& raw, const std::string& dims, const std::string& type, const std::string& out,
                  const std::string& mode) {
    ContainerWriteOptions o;
    o.created = 0;
    ContainerWriteSummary s;
    if (mode == "memory") {
        Volume v = read_volume_file(raw, raw_options(parse_dims(dims), *parse_value_type(type))).take();
        s = write_container(std::move(v), out, o);
    } else {
        auto planes = open_volume_planes(raw, raw_options(parse_dims(dims), *parse_value_type(type)));
        if (mode == "planes512") o.memory_bytes = std::size_t{512} << 20;
        s = write_container(*planes, out, o);
    }
    std::printf("%llu\n", static_cast<unsigned long long>(s.bytes));
    return 0;
}

int child_container_query(const std::string& tlod, int qi) {
    // The dims for the query's box come from the metadata (header, table and
    // METADATA section only), then the query runs lazily.
    auto info = inspect_container(tlod);
    if (!info) {
        std::printf("%s\n", info.failure().message.c_str());
        return 1;
    }
    const Dims d = info->metadata.dims;
    auto x = extract_from_container(tlod, ModelKind::Ht, LodQuery{}, [qi, d](LodQuery& q, const std::array<double, 2>& r) {
        q = kQueries[qi].make(d, r);
    });
    if (!x) {
        std::printf("%s\n", x.failure().message.c_str());
        return 1;
    }
    std::printf("%llu %llu %llu %llu %.3f\n", static_cast<unsigned long long>(x->mesh.tet_count()),
                static_cast<unsigned long long>(x->chunks_decoded), static_cast<unsigned long long>(x->chunks_total),
                static_cast<unsigned long long>(x->bytes_read), x->seconds);
    return 0;
}

int child_memory_query(const std::string& raw, const std::string& dims, const std::string& type, int qi) {
    const auto t0 = std::chrono::steady_clock::now();
    const Dims d = parse_dims(dims);
    LodModel m = build_model(ModelKind::Ht, read_volume_file(raw, raw_options(d, *parse_value_type(type))).take());
    const TetMesh mesh = m.extract(kQueries[qi].make(d, m.range));
    std::printf("%llu %.3f\n", static_cast<unsigned long long>(mesh.tet_count()),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return 0;
}

// --full streamed to a .vtu: from the container, or from the raw volume in memory.
int child_full(const std::string& from, const std::string& raw_dims, const std::string& out) {
    const auto t0 = std::chrono::steady_clock::now();
    auto sink = open_mesh_stream(out, "vtu");
    TetMeshCounter counted(*sink);
    LodQuery q;
    q.full = true;
    if (raw_dims.empty()) {
        extract_from_container_to(from, ModelKind::Ht, q, counted).take();
    } else {
        LodModel m = build_model(ModelKind::Ht, read_volume_file(from, raw_options(parse_dims(raw_dims), ValueType::U8)).take());
        m.extract_to(q, counted);
    }
    std::printf("%llu %.3f\n", static_cast<unsigned long long>(counted.tets),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return 0;
}

std::string mb(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.0f MB", v);
    return b;
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<std::string> a(argv + 1, argv + argc);
    if (a.size() == 6 && a[0] == "--convert") return child_convert(a[1], a[2], a[3], a[4], a[5]);
    if (a.size() == 3 && a[0] == "--container-query") return child_container_query(a[1], std::stoi(a[2]));
    if (a.size() == 5 && a[0] == "--memory-query") return child_memory_query(a[1], a[2], a[3], std::stoi(a[4]));
    if (a.size() == 4 && a[0] == "--full") return child_full(a[1], a[2] == "-" ? "" : a[2], a[3]);

    std::vector<int> sizes{129, 257};
    std::vector<Input> inputs;
    std::string dir;
    int full_max = 257;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (a[i] == "--sizes" && i + 1 < a.size()) {
            sizes.clear();
            std::stringstream ss(a[++i]);
            for (std::string t; std::getline(ss, t, ',');) sizes.push_back(std::stoi(t));
        } else if (a[i] == "--real" && i + 3 < a.size()) {
            Input in;
            in.raw = a[i + 1];
            in.name = std::filesystem::path(in.raw).filename().string();
            in.dims = parse_dims(a[i + 2]);
            in.type = *parse_value_type(a[i + 3]);
            inputs.push_back(in);
            i += 3;
        } else if (a[i] == "--dir" && i + 1 < a.size()) {
            dir = a[++i];
        } else if (a[i] == "--full-max" && i + 1 < a.size()) {
            full_max = std::stoi(a[++i]);
        } else {
            std::fprintf(stderr, "usage: bench_scale [--sizes 129,257,513] [--real FILE.raw X,Y,Z TYPE] [--dir DIR] [--full-max N]\n");
            return 2;
        }
    }
    const bool keep = !dir.empty();
    if (dir.empty()) dir = "bench_scale_files";
    std::filesystem::create_directories(dir);
    std::vector<Input> all;
    for (int n : sizes) {
        Input in;
        in.name = "multiscale " + std::to_string(n) + "^3";
        in.dims = Dims{n, n, n};
        in.raw = dir + "/multiscale_" + std::to_string(n) + ".raw";
        if (!std::filesystem::exists(in.raw)) write_raw_volume(make_sample_volume("multiscale", in.dims), in.raw);
        all.push_back(in);
    }
    all.insert(all.end(), inputs.begin(), inputs.end());

    std::printf("convert: plane by plane (default budget: a quarter of RAM; and --memory 512M) | peer: the volume in memory\n");
    std::printf("%-26s %10s %9s %10s %9s %10s | %9s %10s %12s %s\n", "volume", "points", "planes", "peak RSS", "512M",
                "peak RSS", "memory", "peak RSS", ".tlod", "same bytes");
    std::vector<std::string> containers;
    for (const Input& in : all) {
        const std::string stem = dir + "/" + std::filesystem::path(in.raw).stem().string();
        const std::string tlod = stem + ".tlod";
        const std::string d = std::to_string(in.dims.x) + "," + std::to_string(in.dims.y) + "," + std::to_string(in.dims.z);
        Child c[3];
        const char* modes[3] = {"planes", "planes512", "memory"};
        std::string bytes[3];
        for (int m = 0; m < 3; ++m) {
            const std::string out = m == 0 ? tlod : stem + "." + modes[m] + ".tlod";
            std::filesystem::remove(out);
            c[m] = run_child({"--convert", in.raw, d, value_type_name(in.type), out, modes[m]});
            bytes[m] = slurp(out);
            if (m > 0) std::filesystem::remove(out);
        }
        const bool same = !bytes[0].empty() && bytes[0] == bytes[1] && bytes[0] == bytes[2];
        bool failed = false;
        for (const Child& x : c) failed = failed || x.status != 0;
        std::printf("%-26s %10lld %8.1fs %10s %8.1fs %10s | %8.1fs %10s %12s %s%s\n", in.name.c_str(),
                    static_cast<long long>(in.dims.count()), c[0].seconds, mb(c[0].peak_mb).c_str(), c[1].seconds,
                    mb(c[1].peak_mb).c_str(), c[2].seconds, mb(c[2].peak_mb).c_str(),
                    format_bytes(std::filesystem::file_size(tlod)).c_str(), same ? "yes" : "NO",
                    failed ? "  FAILED" : "");
        std::fflush(stdout);
        containers.push_back(tlod);
    }
    std::printf("\nqueries: from the container (lazy) | peer: the volume in memory (read + build + extract)\n");
    std::printf("(stored errors are rounded up to 4 mantissa bits, so container meshes may be a little finer)\n");
    std::printf("%-26s %-20s %10s %9s %10s %14s %10s | %10s %9s %10s\n", "volume", "query", "tets", "time", "peak RSS",
                "chunks", "read", "tets", "time", "peak RSS");
    for (std::size_t v = 0; v < all.size(); ++v) {
        const Input& in = all[v];
        const std::string d = std::to_string(in.dims.x) + "," + std::to_string(in.dims.y) + "," + std::to_string(in.dims.z);
        for (std::size_t q = 0; q < std::size(kQueries); ++q) {
            const Child c = run_child({"--container-query", containers[v], std::to_string(q)});
            unsigned long long tets = 0, done = 0, total = 0, bytes = 0;
            double sec = 0;
            std::sscanf(c.out.c_str(), "%llu %llu %llu %llu %lf", &tets, &done, &total, &bytes, &sec);
            const Child p = run_child({"--memory-query", in.raw, d, value_type_name(in.type), std::to_string(q)});
            unsigned long long ptets = 0;
            std::sscanf(p.out.c_str(), "%llu", &ptets);
            char chunks[32];
            std::snprintf(chunks, sizeof chunks, "%llu/%llu", done, total);
            std::printf("%-26s %-20s %10llu %8.2fs %10s %14s %10s | %10llu %8.2fs %10s%s\n", in.name.c_str(),
                        kQueries[q].name, tets, c.seconds, mb(c.peak_mb).c_str(), chunks, format_bytes(bytes).c_str(),
                        ptets, p.seconds, mb(p.peak_mb).c_str(), c.status != 0 || p.status != 0 ? "  FAILED" : "");
            std::fflush(stdout);
        }
    }

    // --full to .vtu: tetlod streamed (container, memory) against VTK, tets per second.
    std::printf("\n--full to .vtu (zlib), end to end: tetlod streamed from the container and from memory | "
                "VTK vtkDataSetTriangleFilter + vtkXMLUnstructuredGridWriter (zlib)\n");
    std::printf("%-26s %11s %8s %9s %9s | %8s %9s %9s | %11s %8s %9s | %s\n", "volume", "tets", "time", "Mtets/s",
                "peak RSS", "time", "Mtets/s", "peak RSS", "VTK tets", "time", "Mtets/s", "tetlod/VTK (container / memory)");
    const bool vtk = std::system("/usr/bin/python3 -c 'import vtk' >/dev/null 2>&1") == 0;
    for (std::size_t v = 0; v < all.size(); ++v) {
        const Input& in = all[v];
        if (in.type != ValueType::U8 || std::max({in.dims.x, in.dims.y, in.dims.z}) > full_max) continue;
        const std::string d = std::to_string(in.dims.x) + "," + std::to_string(in.dims.y) + "," + std::to_string(in.dims.z);
        const std::string out = dir + "/full.vtu";
        std::filesystem::remove(out);
        const Child c = run_child({"--full", containers[v], "-", out});
        std::filesystem::remove(out);
        const Child m = run_child({"--full", in.raw, d, out});
        std::filesystem::remove(out);
        unsigned long long tets = 0, mtets = 0;
        std::sscanf(c.out.c_str(), "%llu", &tets);
        std::sscanf(m.out.c_str(), "%llu", &mtets);
        double vtk_tets = 0, vtk_seconds = 0;
        if (vtk) {
            const std::string cmd = "/usr/bin/python3 " + std::string(TETLOD_BENCH_DIR) + "/peer_vtk_full_mesh.py " +
                                    in.raw + " " + std::to_string(in.dims.x) + " " + std::to_string(in.dims.y) + " " +
                                    std::to_string(in.dims.z) + " " + out;
            const auto t0 = std::chrono::steady_clock::now();
            if (std::FILE* f = popen(cmd.c_str(), "r")) {
                char line[512] = {};
                if (std::fgets(line, sizeof line, f)) std::sscanf(line, "VTK: %lf tets", &vtk_tets);
                pclose(f);
            }
            vtk_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::filesystem::remove(out);
        }
        const double rate_c = double(tets) / c.seconds / 1e6, rate_m = double(mtets) / m.seconds / 1e6;
        const double rate_v = vtk_tets > 0 ? vtk_tets / vtk_seconds / 1e6 : 0;
        char ratio[48] = "n/a (no vtk)";
        if (rate_v > 0) std::snprintf(ratio, sizeof ratio, "%.2fx / %.2fx", rate_c / rate_v, rate_m / rate_v);
        std::printf("%-26s %11llu %7.2fs %9.2f %9s | %7.2fs %9.2f %9s | %11.0f %7.2fs %9.2f | %s%s\n",
                    in.name.c_str(), tets, c.seconds, rate_c, mb(c.peak_mb).c_str(), m.seconds, rate_m,
                    mb(m.peak_mb).c_str(), vtk_tets, vtk_seconds, rate_v, ratio,
                    c.status != 0 || m.status != 0 ? "  FAILED" : "");
        std::fflush(stdout);
    }
    std::printf("(VTK's times include starting Python and reading the file; tetlod's include starting the process, "
                "reading, and for memory, building the HT)\n");
    if (!keep) std::filesystem::remove_all(dir);
}
