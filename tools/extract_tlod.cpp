// Lazy extraction from a .tlod container (see extract_tlod.hpp).
#include "extract_tlod.hpp"

#include <filesystem>
#include <ostream>

#include "cli_common.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::cli {

namespace {

int run_extract_tlod_mt(TlodExtractRequest& a, tlod::ContainerReader& r, const Stopwatch& clock) {
    if (!container_has_mt(r))
        throw Error(ErrorCode::NotFound, "'" + a.input + "': --model mt: the container holds no MT "
                                         "(write one with `tetlod convert IN OUT.tlod --model ht,mt`)");
    auto layout = read_mt_layout(r);
    if (!layout) throw Error(layout.failure().code, layout.failure().message);
    auto model = decode_mt_container(r);
    if (!model) throw Error(model.failure().code, model.failure().message);
    const std::array<double, 2> range = layout->metadata.value_range;
    if (a.error_in) a.query.error_in = a.error_in(range);
    if (a.error_out) a.query.error_out = a.error_out(range);
    MtExtractStats stats;
    const TetMesh mesh = model->extract(a.query, &stats);
    const double extract_seconds = clock.seconds();
    MeshWriteOptions wo;
    wo.compress = a.compress;
    write_tet_mesh(mesh, a.output, a.format, wo);
    auto& o = out();
    o << "input    " << a.input << ": " << format_dims(layout->metadata.dims) << " "
      << value_type_name(layout->metadata.type) << " (.tlod, MT: " << model->updates().size()
      << " vertex splits, field " << (layout->with_ht ? "from the HT" : "in the MT") << ")\n";
    o << "mesh     " << mesh.tet_count() << " tets, " << mesh.vertex_count() << " vertices, "
      << format_seconds(extract_seconds) << "\n";
    o << "wrote    " << a.output << "\n";
    return 0;
}

}  // namespace

int run_extract_tlod(TlodExtractRequest a) {
    Stopwatch clock;
    auto r = tlod::ContainerReader::open(a.input);
    if (!r) throw Error(r.failure().code, r.failure().message);
    if (a.model == "mt") return run_extract_tlod_mt(a, *r, clock);
    auto layout = read_ht_layout(*r);
    if (!layout) throw Error(layout.failure().code, layout.failure().message);
    const std::array<double, 2> range = layout->metadata.value_range;
    if (a.error_in) a.query.error_in = a.error_in(range);
    if (a.error_out) a.query.error_out = a.error_out(range);
    HtExtractStats stats;
    HtLazyStats lazy;
    auto mesh = extract_ht_lazy(*r, a.query, &stats, &lazy);
    if (!mesh) throw Error(mesh.failure().code, mesh.failure().message);
    const double extract_seconds = clock.seconds();
    MeshWriteOptions wo;
    wo.compress = a.compress;
    write_tet_mesh(*mesh, a.output, a.format, wo);
    std::error_code ec;
    const auto file_size = std::filesystem::file_size(a.input, ec);
    auto& o = out();
    o << "input    " << a.input << ": " << format_dims(layout->metadata.dims) << " "
      << value_type_name(layout->metadata.type) << " (.tlod, lazy)\n";
    o << "mesh     " << mesh->tet_count() << " tets, " << mesh->vertex_count()
      << " vertices, largest error " << format_error(stats.max_error, range) << "\n";
    o << "read     " << format_bytes(lazy.bytes_read) << " of " << format_bytes(file_size) << ", "
      << lazy.chunks_decoded << " of " << lazy.chunks_total << " chunks, " << lazy.passes
      << " passes, " << format_seconds(extract_seconds) << "\n";
    o << "wrote    " << a.output << "\n";
    return 0;
}

}  // namespace tetlod::cli
