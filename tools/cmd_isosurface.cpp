// tetlod isosurface: the isosurface(s) of a volume or .tlod as a triangle mesh,
// by marching tetrahedra on a selectively refined mesh. By default the isovalue
// query: exact (--error 0) in the tets an isosurface may cross, --error-out
// (default unbounded) elsewhere, which cannot change the surface's topology
// where the query refines and keeps the tet mesh small.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <ostream>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"
#include "model_choice.hpp"

namespace tetlod::cli {

namespace {

struct IsoArgs {
    std::string input, output, model, error = "0", error_out, box, format;
    std::vector<std::string> isovalues;
    RegionFlags regions;
    bool ascii = false, pad = false, no_normals = false, ply_extras = false;
    VolumeFlags volume;
};

int run_isosurface(const IsoArgs& a) {
#if !TETLOD_HAVE_OPENMESH
    (void)a;
    throw Error(ErrorCode::NotBuilt,
                "this tetlod was built without the surface writers (TETLOD_WITH_OPENMESH=OFF)");
#else
    if (a.isovalues.empty())
        throw Error(ErrorCode::InvalidArgument, "give at least one --isovalue V");
    const auto error_in = parse_error_threshold(a.error, "--error");
    const auto error_out = parse_error_threshold(a.error_out.empty() ? "inf" : a.error_out, "--error-out");
    LodQuery query;
    for (const auto& s : a.isovalues) query.isovalues.push_back(parse_number(s, "--isovalue"));
    if (!a.box.empty()) query.box = parse_box(a.box, "--box");
    apply_region_flags(a.regions, query);

    const LodModel model = load_model(a.input, resolve_model(a.model, a.input), a.volume, a.pad, false);
    const auto range = model.range;
    query.error_in = error_in.resolve(range);
    query.error_out = error_out.resolve(range);

    Stopwatch extract_clock;
    const TetMesh mesh = model.extract(query);
    const double extract_seconds = extract_clock.seconds();
    Stopwatch iso_clock;
    IsosurfaceStats stats;
    TriangleMesh surface = marching_tetrahedra(mesh, query.isovalues, &stats);
    const double iso_seconds = iso_clock.seconds();
    SurfaceWriteOptions wo;
    wo.binary = !a.ascii;
    wo.normals = !a.no_normals;
    wo.ply_extras = a.ply_extras;
    Stopwatch write_clock;
    write_surface(surface, a.output, a.format, wo);
    const double write_seconds = write_clock.seconds();

    auto& o = out();
    o << "input    " << with_stdin_named(a.input) << ": " << format_dims(model.dims) << ", values "
      << format_number(range[0]) << ".." << format_number(range[1]) << ", model "
      << model_kind_name(model.kind) << "\n";
    o << "query    error <= " << format_error(query.error_in, range) << " in the region ("
      << describe_region(query, a.box) << "), " << format_error(query.error_out, range) << " elsewhere\n";
    o << "tets     " << mesh.tet_count() << " (" << stats.crossed_tets << " crossed)\n";
    o << "surface  " << surface.face_count() << " triangles, " << surface.vertex_count()
      << " vertices";
    if (stats.degenerate_faces + stats.cancelled_faces)
        o << ", " << stats.degenerate_faces + stats.cancelled_faces
          << " of zero area dropped (samples equal to an isovalue)";
    o << "\n";
    o << "time     " << (model.from_container ? "load " : "build ")
      << format_seconds(model.build_seconds) << ", extract " << format_seconds(extract_seconds)
      << ", isosurface " << format_seconds(iso_seconds) << ", write " << format_seconds(write_seconds)
      << "\n";
    std::error_code ec;
    const auto size = std::filesystem::file_size(a.output, ec);
    o << "wrote    " << a.output << " (" << (ec ? std::string("?") : format_bytes(size)) << ")\n";
    return 0;
#endif
}

const CommandRegistration isosurface_registration{Command{
    "isosurface", "Extract isosurfaces as a triangle mesh (PLY, OBJ, OFF, STL)", 25,
    [](CLI::App& sub) -> std::function<int()> {
        auto a = std::make_shared<IsoArgs>();
        sub.add_option("input", a->input, "Input volume or .tlod file")->required();
        sub.add_option("output", a->output, "Output surface (.ply, .obj, .off, .stl)")->required();
        add_volume_flags(sub, a->volume);
        const std::string lod = "Surface and level of detail";
        const auto threshold = check_with([](const std::string& s) { parse_error_threshold(s, ""); });
        sub.add_option("--isovalue", a->isovalues, "Isovalue V (repeat or V1,V2 for several surfaces)")
            ->group(lod)
            ->allow_extra_args(false)
            ->delimiter(',')
            ->check(check_with([](const std::string& s) { parse_number(s, ""); }));
        sub.add_option("--error", a->error,
                       "Largest error in tets the surface may cross (E, E%, inf)")
            ->group(lod)
            ->capture_default_str()
            ->check(threshold);
        sub.add_option("--error-out", a->error_out, "Largest error elsewhere (default inf)")
            ->group(lod)
            ->check(threshold);
        sub.add_option("--box", a->box, "Only refine inside index box x0,y0,z0,x1,y1,z1")
            ->group(lod)
            ->check(check_with([](const std::string& s) { parse_box(s, ""); }));
        add_region_flags(sub, a->regions, lod);
        const std::string model = "Model and output";
        sub.add_option("--model", a->model, "Multiresolution model: ht or mt (a .tlod must hold it; default: ht, or the MT "
                       "of a .tlod holding only an MT)")
            ->group(model)
            ->check(CLI::IsMember({"ht", "mt"}));
        sub.add_flag("--pad", a->pad, "HT: embed the volume in the enclosing (2^k+1)^3 cube")
            ->group(model);
        sub.add_option("--format", a->format, "Surface format (default: from the extension)")
            ->group(model)
            ->check(CLI::IsMember({"ply", "obj", "off", "stl"}));
        sub.add_flag("--ascii", a->ascii, "ASCII PLY/STL instead of binary")->group(model);
        sub.add_flag("--no-normals", a->no_normals, "Leave vertex normals out")->group(model);
        sub.add_flag("--ply-extras", a->ply_extras,
                     "PLY: add vertex normals and per-face \"error\", \"surface\" (gmsh and "
                     "binary meshio cannot read them)")
            ->group(model);
        sub.footer(
            "Inside is f >= V (samples equal to V count as inside); triangles are\n"
            "counter-clockwise seen from outside, normals point towards decreasing\n"
            "field. PLY is plain (x y z, triangles) for every reader; with --ply-extras\n"
            "it adds normals and per-face \"error\" (source tet's bound) and \"surface\"\n"
            "(isovalue index).\n\n"
            "Examples:\n"
            "  tetlod isosurface bucky_32x32x32_uint8.raw bucky.ply --isovalue 128\n"
            "  tetlod isosurface head.tlod head.stl --isovalue 40 --isovalue 90 --error 1%\n"
            "  tetlod isosurface ml_65x65x65_uint8.raw ml.obj --isovalue 100 --model mt\n");
        return [a] { return run_isosurface(*a); };
    }}};

}  // namespace

}  // namespace tetlod::cli
