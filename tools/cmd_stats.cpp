// tetlod stats: what a model is like before one uses it. For each model of the
// input (a .tlod: its HT; a volume: the HT and MT built from it) the tets against
// the error threshold for uniform, box and isovalue queries, isosurface sizes,
// shape quality, bytes per grid point and extraction times; --plot draws them.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <ostream>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"
#include "model_choice.hpp"
#include "stats_plots.hpp"

namespace tetlod::cli {

namespace {

struct StatsArgs {
    std::string input, plot_dir, models = "all";
    std::vector<std::string> isovalues;
    bool json = false, pad = false;
    VolumeFlags volume;
};

int run_stats(const StatsArgs& a) {
    StatsOptions opt;
    for (const auto& s : a.isovalues) opt.isovalues.push_back(parse_number(s, "--isovalue"));
    std::vector<ModelKind> kinds;
    const bool tlod = is_container_path(a.input);
    if (a.models == "all" && tlod) {  // the models the container holds
        const ContainerModels held = container_models(a.input);
        if (held.ht || !held.mt) kinds.push_back(ModelKind::Ht);  // neither: the HT reader says why
        if (held.mt) kinds.push_back(ModelKind::Mt);
    } else if (a.models == "all") {
        kinds = {ModelKind::Ht, ModelKind::Mt};
    } else
        kinds = {parse_model_kind(a.models)};
    std::vector<ModelStats> stats;
    if (tlod) {
        for (auto k : kinds) {
            const LodModel m = load_model(a.input, k, a.volume, a.pad, true);
            detail("measuring " + std::string(model_kind_name(k)));
            stats.push_back(measure_model(m, model_kind_name(k), opt));
        }
    } else {
        const Volume v = load_volume(a.input, a.volume.options());
        for (auto k : kinds) {
            detail("building " + std::string(model_kind_name(k)));
            const LodModel m = build_model(k, v, ModelBuildOptions{a.pad, true});
            stats.push_back(measure_model(m, model_kind_name(k), opt));
        }
    }
    const std::string dataset = std::filesystem::path(a.input).filename().string();
    if (a.json) {
        nlohmann::json j{{"file", a.input}, {"models", stats_json(stats)}};
        out() << j.dump(2) << "\n";
    } else {
        out() << with_stdin_named(a.input) << "\n" << stats_text(stats);
    }
    if (!a.plot_dir.empty()) {
        const auto files = write_stats_plots(stats, a.plot_dir, dataset);
        if (!a.json)
            out() << "plots    " << files.size() << " SVG + stats.csv, shape_quality.csv in " << a.plot_dir
                  << "\n";
    }
    return 0;
}

const CommandRegistration stats_registration{Command{
    "stats", "Measure a model: tets vs error, queries, shape quality, storage, times", 40,
    [](CLI::App& sub) -> std::function<int()> {
        auto a = std::make_shared<StatsArgs>();
        sub.add_option("input", a->input, "A .tlod file or a volume")->required();
        add_volume_flags(sub, a->volume);
        const std::string g = "Measurements";
        sub.add_option("--model", a->models, "ht, mt or all (for a .tlod: the models it holds)")
            ->group(g)
            ->capture_default_str()
            ->check(CLI::IsMember({"ht", "mt", "all"}));
        sub.add_option("--isovalue", a->isovalues,
                       "Isovalues of the isovalue queries (default 25/50/75% of the range)")
            ->group(g)
            ->allow_extra_args(false)
            ->delimiter(',')
            ->check(check_with([](const std::string& s) { parse_number(s, ""); }));
        sub.add_flag("--pad", a->pad, "HT: embed the volume in the enclosing (2^k+1)^3 cube")->group(g);
        const std::string o = "Output";
        sub.add_flag("--json", a->json, "Print JSON instead of text")->group(o);
        sub.add_option("--plot", a->plot_dir, "Write SVG plots and CSV numbers into DIR")->group(o);
        sub.footer(
            "Error thresholds: 0.1% .. 50% of the value range. Box queries average 8 boxes\n"
            "(1/4 and 1/2 of each axis, 4 positions); isovalue queries average the isovalues.\n\n"
            "Examples:\n"
            "  tetlod stats bucky.tlod\n"
            "  tetlod stats bucky_32x32x32_uint8.raw --json > bucky.json\n"
            "  tetlod stats head_mr_48x62x42_uint8.raw --plot head_plots\n");
        return [a] { return run_stats(*a); };
    }}};

}  // namespace

}  // namespace tetlod::cli
