// Lazy extraction from a container: decode only the chunks the refinement
// examines.
#include "ht_chunk_decoder.hpp"
#include "ht_chunk_geometry.hpp"

namespace tetlod {

using namespace ht_detail;

Expected<TetMesh> extract_ht_lazy(tlod::ContainerReader& r, const LodQuery& query, HtExtractStats* es,
                                  HtLazyStats* ls) {
    auto layout = read_ht_layout(r);
    if (!layout) return layout.failure();
    const HtLayout& L = *layout;
    const Geometry G = geometry_of(L.domain, L.brick_log2);
    std::vector<char> want(L.chunks.size(), 0), done(L.chunks.size(), 0);
    // Undecoded diamonds read as error 0 ("fine"): the refinement then stops
    // at them, and the check below finds every such stop and loads it.
    // Field and errors live in zeroed storage that commits memory only where a
    // chunk is decoded, shared with one model that reads them between passes:
    // no pass copies or scans the grid.
    auto errors = std::make_shared<ZeroedVector<float>>();
    auto allocated = allocate_decoded(r.name(), L, errors.get());
    if (!allocated) return allocated.failure();
    auto field = std::make_shared<Volume>(std::move(*allocated));
    restore_metadata(*field, L.metadata);
    auto built = capture([&] { return HtModel::over_shared_parts(field, L.domain, errors, L.metadata.value_range); },
                         r.name() + ": ");
    if (!built) return built.failure();
    const HtModel& model = *built;
    // Chunk of a grid point of B: cycle from the trailing zeros, brick from the coordinates.
    std::vector<std::size_t> first_of_cycle(std::size_t(G.k + 1), 0);
    for (std::size_t i = L.chunks.size(); i-- > 0;) first_of_cycle[std::size_t(L.chunks[i].cycle)] = i;
    auto chunk_of = [&](const std::array<int32_t, 3>& p) -> std::size_t {
        int t = G.k;
        for (int a = 0; a < 3; ++a)
            if (p[a] != 0) t = std::min(t, std::countr_zero(uint32_t(p[a])));
        const auto n = G.bricks(t);
        int64_t bi[3];
        for (int a = 0; a < 3; ++a) bi[a] = std::min<int64_t>(p[a] / G.side(t), n[a] - 1);
        return first_of_cycle[std::size_t(t)] + std::size_t((bi[2] * n[1] + bi[1]) * n[0] + bi[0]);
    };
    // Start with the three coarsest cycles (a small prefix of the file).
    for (std::size_t i = 0; i < L.chunks.size(); ++i) want[i] = L.chunks[i].cycle >= G.k - 2;
    HtLazyStats st;
    st.chunks_total = L.chunks.size();
    const int max_level = 3 * G.k;
    for (;;) {
        add_dependencies(L, want);
        auto n = decode_chunks(r, L, want, done, *field, errors.get());
        if (!n) return n.failure();
        st.chunks_decoded += *n;
        ++st.passes;
        TetMesh mesh = model.extract(query, es);
        // The mesh is the true one iff every vertex and the diamond under every
        // non-finest tet (centred at its longest edge's midpoint, the one the
        // refinement judged) are decoded.
        bool missing = false;
        auto need = [&](const std::array<int32_t, 3>& p) {
            const std::size_t c = chunk_of(p);
            if (!done[c]) {
                want[c] = 1;
                missing = true;
            }
        };
        for (const auto& p : mesh.points) need(p);
        for (std::size_t ti = 0; ti < mesh.tets.size(); ++ti) {
            if (mesh.level[ti] >= max_level) continue;
            const auto& tv = mesh.tets[ti];
            int64_t best = -1;
            std::array<int32_t, 3> mid{};
            for (int a = 0; a < 4; ++a)
                for (int b = a + 1; b < 4; ++b) {
                    const auto& P = mesh.points[tv[a]];
                    const auto& Q = mesh.points[tv[b]];
                    int64_t d2 = 0;
                    for (int q = 0; q < 3; ++q) d2 += int64_t(P[q] - Q[q]) * (P[q] - Q[q]);
                    if (d2 > best) {
                        best = d2;
                        for (int q = 0; q < 3; ++q) mid[q] = (P[q] + Q[q]) / 2;
                    }
                }
            if (L.domain.in_box(mid[0], mid[1], mid[2])) need(mid);
        }
        if (!missing) {
            st.bytes_read = r.bytes_read();
            if (ls) *ls = st;
            return mesh;
        }
    }
}

}  // namespace tetlod
