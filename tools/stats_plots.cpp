// The plots and tables of the model statistics (see stats_plots.hpp).
#include "stats_plots.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "svg_plot.hpp"

namespace tetlod::cli {

std::vector<std::pair<std::string, std::string>> write_stats_plots(
    const std::vector<ModelStats>& models, const std::string& dir, const std::string& dataset) {
    std::filesystem::create_directories(dir);
    std::vector<std::pair<std::string, std::string>> files;
    auto save = [&](const std::string& name, const Plot& p, const std::string& caption) {
        const std::string svg = render_svg(p);
        write_file_atomic(dir + "/" + name, svg.data(), svg.size());
        files.emplace_back(name, caption);
    };
    std::string range_note;
    if (!models.empty())
        range_note = "value range " + format_number(models[0].range[0]) + ".." + format_number(models[0].range[1]);
    auto lines = [&](const std::vector<QueryRow> ModelStats::*rows, double QueryRow::*y,
                     const std::string& suffix) {
        std::vector<PlotSeries> ss;
        for (std::size_t mi = 0; mi < models.size(); ++mi) {
            const auto& m = models[mi];
            PlotSeries s;
            s.label = m.name + suffix;
            s.color = int(mi);
            for (const auto& r : m.*rows) s.x.push_back(r.error), s.y.push_back(r.*y);
            ss.push_back(s);
        }
        return ss;
    };
    {
        Plot p;
        p.title = "Uniform LOD: tetrahedra vs error threshold";
        p.subtitle = dataset + ", " + range_note + " (cf. paper Fig. 3)";
        p.x_label = "error threshold (field units)";
        p.y_label = "tetrahedra";
        p.log_x = p.log_y = true;
        p.series = lines(&ModelStats::uniform, &QueryRow::tets, "");
        for (std::size_t mi = 0; mi < models.size(); ++mi) {
            const auto& m = models[mi];
            PlotSeries s;
            s.label = m.name + " full resolution";
            s.dashed = true;
            s.color = int(mi);
            for (const auto& r : m.uniform) s.x.push_back(r.error), s.y.push_back(double(m.full_tets));
            p.series.push_back(s);
        }
        save("uniform_tets.svg", p, "Tetrahedra of the uniform LOD mesh against the error threshold (dashed: full resolution).");
    }
    {
        Plot p;
        p.title = "Box queries: tetrahedra vs error threshold";
        p.subtitle = dataset + ", mean over " + std::to_string(models.empty() ? 0 : models[0].boxes) +
                     " boxes (1/4 and 1/2 of each axis, 4 positions), inf outside (cf. Fig. 5)";
        p.x_label = "error threshold inside the box (field units)";
        p.y_label = "tetrahedra (mean)";
        p.log_x = p.log_y = true;
        p.series = lines(&ModelStats::box, &QueryRow::tets, "");
        save("box_tets.svg", p, "Box queries: mean tetrahedra over boxes of two sizes at four positions, error unbounded outside.");
    }
    {
        Plot p;
        p.title = "Isovalue queries: tetrahedra and isosurface triangles";
        std::string iv;
        if (!models.empty())
            for (double v : models[0].isovalues) iv += (iv.empty() ? "" : ", ") + format_number(v);
        p.subtitle = dataset + ", mean over isovalues " + iv + ", inf elsewhere (cf. Fig. 7)";
        p.x_label = "error threshold near the isosurface (field units)";
        p.y_label = "count (mean)";
        p.log_x = p.log_y = true;
        p.series = lines(&ModelStats::iso, &QueryRow::tets, " tetrahedra");
        auto faces = lines(&ModelStats::iso, &QueryRow::faces, " isosurface triangles");
        for (auto& f : faces) f.dashed = true, p.series.push_back(f);
        save("isovalue_tets.svg", p, "Isovalue queries: tetrahedra of the mesh (solid) and triangles of the isosurface cut from it (dashed).");
    }
    {
        Plot p;
        p.kind = Plot::Kind::Histogram;
        p.title = "Shape quality: circumradius / shortest edge";
        p.subtitle = dataset + ", uniform LOD meshes at error " +
                     (models.empty() ? std::string("?") : format_number(models[0].quality_lod_error)) +
                     " and full resolution; lower is better (cf. Fig. 8)";
        p.x_label = "circumradius / shortest edge";
        p.y_label = "share of tetrahedra (%)";
        for (std::size_t mi = 0; mi < models.size(); ++mi)
            for (int which = 0; which < 2; ++which) {
                const auto& m = models[mi];
                const auto& q = which == 0 ? m.quality_lod : m.quality_full;
                PlotSeries s;
                s.label = m.name + (which == 0 ? " LOD" : " full resolution");
                s.dashed = which == 1;
                s.color = int(mi);
                const int bins = int(q.histogram.size());
                for (int i = 0; i <= bins; ++i) s.x.push_back(q.hist_lo + (q.hist_hi - q.hist_lo) * i / bins);
                for (auto c : q.histogram) s.y.push_back(q.count ? 100.0 * double(c) / double(q.count) : 0);
                p.series.push_back(s);
            }
        p.x_marks = {{std::sqrt(6.0) / 4, "regular tet 0.612"}};
        save("shape_quality.svg", p, "Histogram of the shape ratio (last bin also holds everything above it).");
    }
    {
        Plot p;
        p.title = "Extraction time vs output size";
        p.subtitle = dataset + ", uniform LOD queries";
        p.x_label = "tetrahedra extracted";
        p.y_label = "time (ms)";
        p.log_x = p.log_y = true;
        for (std::size_t mi = 0; mi < models.size(); ++mi) {
            const auto& m = models[mi];
            PlotSeries s;
            s.label = m.name;
            s.color = int(mi);
            for (const auto& r : m.uniform) s.x.push_back(r.tets), s.y.push_back(r.seconds * 1e3);
            p.series.push_back(s);
        }
        save("extract_time.svg", p, "Extraction time of the uniform queries against the tetrahedra they produce.");
    }
    // The numbers, one row per model, query type and threshold.
    std::string csv = "model,query,error,error_fraction,tets,vertices,isosurface_faces,seconds,queries\n";
    for (const auto& m : models) {
        auto rows = [&](const char* kind, const std::vector<QueryRow>& rs) {
            for (const auto& r : rs) {
                char b[256];
                std::snprintf(b, sizeof b, "%s,%s,%.9g,%.6g,%.1f,%.1f,%.1f,%.6f,%d\n", m.name.c_str(), kind,
                              r.error, r.fraction, r.tets, r.vertices, r.faces, r.seconds, r.queries);
                csv += b;
            }
        };
        rows("uniform", m.uniform);
        rows("box", m.box);
        rows("isovalue", m.iso);
    }
    write_file_atomic(dir + "/stats.csv", csv.data(), csv.size());
    std::string qcsv = "model,mesh,bin_lo,bin_hi,count\n";
    for (const auto& m : models)
        for (int which = 0; which < 2; ++which) {
            const auto& q = which == 0 ? m.quality_lod : m.quality_full;
            const int bins = int(q.histogram.size());
            for (int i = 0; i < bins; ++i) {
                char b[160];
                std::snprintf(b, sizeof b, "%s,%s,%.4f,%.4f,%llu\n", m.name.c_str(), which == 0 ? "lod" : "full",
                              q.hist_lo + (q.hist_hi - q.hist_lo) * i / bins,
                              q.hist_lo + (q.hist_hi - q.hist_lo) * (i + 1) / bins,
                              (unsigned long long)q.histogram[i]);
                qcsv += b;
            }
        }
    write_file_atomic(dir + "/shape_quality.csv", qcsv.data(), qcsv.size());
    return files;
}

}  // namespace tetlod::cli
