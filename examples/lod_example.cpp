// A small tetlod program: build a Hierarchy of Tetrahedra from a generated
// volume, extract a uniform level of detail at 1% of the value range, write it
// as .vtu and print what it got. Usage: tetlod_example OUTPUT.vtu
#include <cstdio>
#include <exception>

#include "tetlod/tetlod.hpp"

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s OUTPUT.vtu\n", argv[0]);
        return 2;
    }
    try {
        tetlod::Volume volume = tetlod::make_sample_volume("marschner-lobb", tetlod::Dims{17, 17, 17});
        tetlod::LodModel model = tetlod::build_model(tetlod::ModelKind::Ht, std::move(volume));

        tetlod::LodQuery query;
        query.error_in = 0.01 * (model.range[1] - model.range[0]);
        tetlod::LodExtractStats stats;
        tetlod::TetMesh mesh = model.extract(query, &stats);
        tetlod::write_tet_mesh(mesh, argv[1]);

        std::printf("tetlod %s: %s of %lldx%lldx%lld, %zu tets, %zu vertices, largest error %g\n",
                    tetlod::library_version(), tetlod::model_kind_name(model.kind),
                    static_cast<long long>(model.dims.x), static_cast<long long>(model.dims.y),
                    static_cast<long long>(model.dims.z), mesh.tet_count(), mesh.vertex_count(),
                    stats.max_error);
        return mesh.tet_count() > 0 ? 0 : 1;
    } catch (const tetlod::Error& e) {
        std::fprintf(stderr, "tetlod_example: %s\n", e.what());
        return 1;
    }
}
