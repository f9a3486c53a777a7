// tetlod demo: the whole pipeline on the built-in volumes, with no data needed:
// writes the volumes as raw files and a series of level-of-detail meshes (full,
// uniform, box and isovalue queries) ready to compare side by side in ParaView.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <ostream>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"

namespace tetlod::cli {

namespace {

struct DemoArgs {
    std::string out_dir = "tetlod-demo";
    int64_t size = 65;
};

struct DemoQuery {
    std::string suffix;  // file name part
    std::string label;   // table text
    LodQuery query;
};

// The queries shown for one volume; thresholds in percent of its value range.
std::vector<DemoQuery> demo_queries(const Dims& dims, const std::array<double, 2>& range) {
    const double width = range[1] - range[0];
    auto pct = [&](double p) { return p * width / 100.0; };
    std::vector<DemoQuery> qs;
    DemoQuery full{"full", "full resolution", {}};
    full.query.full = true;
    qs.push_back(full);
    for (int p : {1, 5, 10}) {
        DemoQuery q{"error" + std::to_string(p) + "pct",
                    "uniform, error <= " + std::to_string(p) + "%",
                    {}};
        q.query.error_in = pct(p);
        qs.push_back(q);
    }
    // The middle half of the grid exact, the rest coarse: a focus+context view.
    DemoQuery box{"box", "", {}};
    box.query.box = std::array<int64_t, 6>{dims.x / 4,     dims.y / 4,     dims.z / 4,
                                           3 * dims.x / 4, 3 * dims.y / 4, 3 * dims.z / 4};
    box.label = "box " + std::to_string(dims.x / 4) + ".." + std::to_string(3 * dims.x / 4) +
                ": exact inside, 10% outside";
    box.query.error_in = 0.0;
    box.query.error_out = pct(10);
    qs.push_back(box);
    // Fine only where the mid-range isosurface passes, as coarse as possible elsewhere.
    DemoQuery iso{"iso", "", {}};
    const double isovalue = range[0] + width / 2.0;
    iso.label = "isovalue " + format_number(isovalue) + ": 1% near, unbounded elsewhere";
    iso.query.isovalues = {isovalue};
    iso.query.error_in = pct(1);
    qs.push_back(iso);
    return qs;
}

int run_demo(const DemoArgs& a) {
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::create_directories(a.out_dir, ec);
    if (ec)
        throw Error(ErrorCode::IoError,
                    "cannot create directory '" + a.out_dir + "': " + ec.message());
    const Dims dims{a.size, a.size, a.size};
    auto& o = out();
    // The demo regenerates its own fixed set of files in --out on every run.
    if (auto* policy = active_output_policy()) policy->force = true;

    char line[512];
    for (const std::string name : {"marschner-lobb", "multiscale"}) {
        Volume volume = make_sample_volume(name, dims, ValueType::U8);
        // The conventional name lets 'tetlod extract' read the file back without flags.
        const std::string raw =
            (fs::path(a.out_dir) / (name + "_" + format_dims(dims) + "_uint8.raw")).string();
        write_raw_volume(volume, raw, Endian::Little);
        o << "wrote " << raw << " (" << format_bytes(volume.bytes()) << ")\n";
        mark_reported(raw);

        const LodModel model = build_model(ModelKind::Ht, std::move(volume));
        o << "built the HT of " << name << " in " << format_seconds(model.build_seconds) << "\n";
        const auto range = model.range;
        std::snprintf(line, sizeof line, "%-34s %-44s %9s %9s %-22s %9s\n", "file", "query", "tets",
                      "vertices", "max error", "extract");
        o << line;
        for (const auto& q : demo_queries(dims, range)) {
            LodExtractStats stats;
            Stopwatch clock;
            const TetMesh mesh = model.extract(q.query, &stats);
            const double seconds = clock.seconds();
            const std::string file = name + "_" + q.suffix + ".vtu";
            write_tet_mesh(mesh, (fs::path(a.out_dir) / file).string());
            mark_reported((fs::path(a.out_dir) / file).string());  // listed in the table
            std::snprintf(line, sizeof line, "%-34s %-44s %9zu %9zu %-22s %9s\n", file.c_str(),
                          q.label.c_str(), mesh.tet_count(), mesh.vertex_count(),
                          format_error(stats.max_error, range).c_str(),
                          format_seconds(seconds).c_str());
            o << line;
        }
        o << "\n";
    }
    o << "open them in ParaView: paraview " << (fs::path(a.out_dir) / "*.vtu").string() << "\n";
    return 0;
}

const CommandRegistration demo_registration{
    Command{"demo", "Run the pipeline on the built-in volumes and write meshes to compare", 90,
            [](CLI::App& sub) -> std::function<int()> {
                auto a = std::make_shared<DemoArgs>();
                sub.add_option("--out", a->out_dir, "Output directory (created if missing)")
                    ->capture_default_str();
                sub.add_option("--size", a->size, "Samples along each axis of the volumes")
                    ->capture_default_str()
                    ->check(CLI::Range(int64_t{2}, int64_t{1025}));
                sub.footer(
                    "Examples:\n"
                    "  tetlod demo\n"
                    "  tetlod demo --out /tmp/lod --size 129 && paraview /tmp/lod/*.vtu\n");
                return [a] { return run_demo(*a); };
            }}};

}  // namespace

}  // namespace tetlod::cli
