// Model statistics: the queries of the comparison and their JSON and text forms
// (see model_stats.hpp).
#include "tetlod/analysis/model_stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "tetlod/analysis/stopwatch.hpp"
#include "tetlod/analysis/text_format.hpp"
#include "tetlod/models/isosurface.hpp"

namespace tetlod {
namespace {

// Boxes: two sizes (1/4 and 1/2 of each axis) at four positions, centres given
// as fractions of the extent, clamped inside the data.
const double kBoxSizes[] = {0.25, 0.5};
const double kBoxCentres[][3] = {{0.5, 0.5, 0.5}, {0.25, 0.25, 0.25}, {0.75, 0.75, 0.75}, {0.25, 0.75, 0.5}};

std::array<int64_t, 6> box_at(const Dims& d, double size, const double* c) {
    std::array<int64_t, 6> b{};
    const int64_t n[3] = {d.x, d.y, d.z};
    for (int a = 0; a < 3; ++a) {
        const int64_t ext = n[a] - 1;
        const int64_t w = std::max<int64_t>(1, std::llround(size * double(ext)));
        int64_t lo = std::llround(c[a] * double(ext)) - w / 2;
        lo = std::clamp<int64_t>(lo, 0, ext - w);
        b[a] = lo, b[a + 3] = lo + w;
    }
    return b;
}

void add(QueryRow& r, const TetMesh& m, double seconds) {
    r.tets += double(m.tet_count());
    r.vertices += double(m.vertex_count());
    r.seconds += seconds;
    ++r.queries;
}
void average(QueryRow& r) {
    if (r.queries == 0) return;
    r.tets /= r.queries, r.vertices /= r.queries, r.faces /= r.queries, r.seconds /= r.queries;
}

nlohmann::json rows_json(const std::vector<QueryRow>& rows, bool faces) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& r : rows) {
        nlohmann::json j{{"error", r.error}, {"error_fraction", r.fraction}, {"tets", r.tets},
                         {"vertices", r.vertices}, {"seconds", r.seconds}, {"queries", r.queries}};
        if (faces) j["isosurface_faces"] = r.faces;
        a.push_back(j);
    }
    return a;
}

nlohmann::json quality_json(const ShapeQualityStats& q) {
    return {{"count", q.count}, {"min", q.min}, {"mean", q.mean}, {"max", q.max},
            {"hist_lo", q.hist_lo}, {"hist_hi", q.hist_hi}, {"histogram", q.histogram}};
}

std::string fmt(const char* f, double v) {
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

}  // namespace

ModelStats measure_model(const LodModel& model, const std::string& name, const StatsOptions& opt) {
    ModelStats s;
    s.name = name;
    s.dims = model.dims;
    s.range = model.range;
    s.grid_points = model.grid_points();
    s.stored_bytes = model.stored_bytes;
    s.stored_what = model.stored_what;
    s.memory_bytes = model.memory_bytes;
    s.updates = model.updates;
    s.build_seconds = model.build_seconds;
    s.from_container = model.from_container;
    s.field_error = model.field_error;
    s.tets_per_split = model.tets_per_split;
    const double span = model.range[1] - model.range[0];
    s.isovalues = opt.isovalues;
    if (s.isovalues.empty())
        for (double f : {0.25, 0.5, 0.75}) s.isovalues.push_back(model.range[0] + f * span);

    {
        LodQuery q;
        q.full = true;
        Stopwatch c;
        const TetMesh m = model.extract(q);
        s.full_seconds = c.seconds();
        s.full_tets = m.tet_count();
        s.full_vertices = m.vertex_count();
        s.quality_full = shape_quality(m);
    }
    {
        LodQuery q;
        q.error_in = opt.quality_fraction * span;
        s.quality_lod_error = q.error_in;
        s.quality_lod = shape_quality(model.extract(q));
    }
    for (double f : opt.error_fractions) {
        const double e = f * span;
        QueryRow u{e, f}, b{e, f}, iso{e, f};
        {
            LodQuery q;
            q.error_in = e;
            Stopwatch c;
            const TetMesh m = model.extract(q);
            add(u, m, c.seconds());
        }
        for (double size : kBoxSizes)
            for (const auto& centre : kBoxCentres) {
                LodQuery q;
                q.error_in = e;
                q.box = box_at(model.dims, size, centre);
                Stopwatch c;
                const TetMesh m = model.extract(q);
                add(b, m, c.seconds());
            }
        for (double v : s.isovalues) {
            LodQuery q;
            q.error_in = e;
            q.isovalues = {v};
            Stopwatch c;
            const TetMesh m = model.extract(q);
            add(iso, m, c.seconds());
            const double vs[] = {v};
            iso.faces += double(marching_tetrahedra(m, vs).face_count());
        }
        average(u), average(b), average(iso);
        s.uniform.push_back(u), s.box.push_back(b), s.iso.push_back(iso);
    }
    s.boxes = int(std::size(kBoxSizes) * std::size(kBoxCentres));
    return s;
}

nlohmann::json stats_json(const std::vector<ModelStats>& models) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& s : models) {
        nlohmann::json j{
            {"model", s.name},
            {"dims", {s.dims.x, s.dims.y, s.dims.z}},
            {"value_range", {s.range[0], s.range[1]}},
            {"grid_points", s.grid_points},
            {"build_seconds", s.build_seconds},
            {"loaded_from_container", s.from_container},
            {"memory_bytes", s.memory_bytes},
            {"memory_bytes_per_point", double(s.memory_bytes) / double(s.grid_points)},
            {"full", {{"tets", s.full_tets}, {"vertices", s.full_vertices}, {"seconds", s.full_seconds}}},
            {"uniform", rows_json(s.uniform, false)},
            {"box", rows_json(s.box, false)},
            {"boxes_per_threshold", s.boxes},
            {"isovalue", rows_json(s.iso, true)},
            {"isovalues", s.isovalues},
            {"shape_quality_full", quality_json(s.quality_full)},
            {"shape_quality_lod", quality_json(s.quality_lod)},
            {"shape_quality_lod_error", s.quality_lod_error},
        };
        if (s.stored_bytes) {
            j["stored_bytes"] = s.stored_bytes;
            j["stored_what"] = s.stored_what;
            j["stored_bytes_per_point"] = double(s.stored_bytes) / double(s.grid_points);
        }
        if (s.tets_per_split) j["tets_per_split"] = *s.tets_per_split;
        j["field_max_error"] = s.field_error;
        a.push_back(j);
    }
    return a;
}

std::string stats_text(const std::vector<ModelStats>& models) {
    std::ostringstream o;
    for (const auto& s : models) {
        o << s.name << "  " << format_dims(s.dims) << ", values " << format_number(s.range[0]) << ".."
          << format_number(s.range[1]) << ", " << (s.from_container ? "loaded in " : "built in ")
          << format_seconds(s.build_seconds) << "\n";
        if (s.stored_bytes)
            o << "  storage      " << format_bytes(s.stored_bytes) << " = "
              << fmt("%.2f", double(s.stored_bytes) / double(s.grid_points)) << " bytes/point ("
              << s.stored_what << "); in memory "
              << fmt("%.2f", double(s.memory_bytes) / double(s.grid_points)) << " bytes/point\n";
        else
            o << "  storage      in memory " << fmt("%.2f", double(s.memory_bytes) / double(s.grid_points))
              << " bytes/point\n";
        if (s.field_error > 0)
            // Why the rows below it repeat the full mesh: the finest tets state it.
            o << "  lossy field  every sample within " << format_number(s.field_error)
              << " of the original; thresholds below it give the full mesh\n";
        o << "  full mesh    " << s.full_tets << " tets, " << s.full_vertices << " vertices ("
          << format_seconds(s.full_seconds) << ")\n";
        if (s.tets_per_split) o << "  tets added per vertex split: " << fmt("%.2f", *s.tets_per_split) << "\n";
        o << "  quality      full: min " << fmt("%.3f", s.quality_full.min) << " mean "
          << fmt("%.3f", s.quality_full.mean) << " max " << fmt("%.3f", s.quality_full.max)
          << "; uniform at error " << format_number(s.quality_lod_error) << ": min "
          << fmt("%.3f", s.quality_lod.min) << " mean " << fmt("%.3f", s.quality_lod.mean) << " max "
          << fmt("%.3f", s.quality_lod.max) << "\n";
        o << "  error        uniform tets   box tets (avg " << s.boxes << ")   isovalue tets   iso faces   extract (uniform)\n";
        for (std::size_t i = 0; i < s.uniform.size(); ++i) {
            char b[200];
            std::snprintf(b, sizeof b, "  %-11s %13.0f %21.0f %15.0f %11.0f   %s\n",
                          format_number(s.uniform[i].error).c_str(), s.uniform[i].tets, s.box[i].tets,
                          s.iso[i].tets, s.iso[i].faces, format_seconds(s.uniform[i].seconds).c_str());
            o << b;
        }
    }
    return o.str();
}

}  // namespace tetlod
