// Whole (or partial, by cycle and box) decode of the HT; the original volume.
#include <cstring>
#include <fstream>

#include "ht_chunk_decoder.hpp"
#include "ht_chunk_geometry.hpp"

namespace tetlod {

using namespace ht_detail;

Expected<HtDecoded> decode_ht(tlod::ContainerReader& r, const HtDecodeRequest& req) {
    auto layout = read_ht_layout(r);
    if (!layout) return layout.failure();
    HtDecoded out;
    out.layout = std::move(*layout);
    const HtLayout& L = out.layout;
    const Geometry G = geometry_of(L.domain, L.brick_log2);
    std::vector<char> want(L.chunks.size(), 0), done(L.chunks.size(), 0);
    const std::array<int64_t, 6> region = req.box.value_or(std::array<int64_t, 6>{
        0, 0, 0, G.box_max[0], G.box_max[1], G.box_max[2]});
    for (std::size_t i = 0; i < L.chunks.size(); ++i) {
        const HtChunk& c = L.chunks[i];
        if (c.cycle < req.finest_cycle) continue;
        bool meet = true;
        for (int a = 0; a < 3; ++a) meet = meet && c.box[a] <= region[3 + a] && region[a] <= c.box[3 + a];
        want[i] = meet;
    }
    add_dependencies(L, want);
    // Cube corners are not diamonds: their error stays 0.
    ZeroedVector<float> errors;
    auto allocated = allocate_decoded(r.name(), L, req.errors ? &errors : nullptr);
    if (!allocated) return allocated.failure();
    Volume field = std::move(*allocated);
    auto n = decode_chunks(r, L, want, done, field, req.errors ? &errors : nullptr, req.progress);
    if (!n) return n.failure();
    out.chunks_decoded = *n;
    if (req.errors) {
        // Diamonds of chunks left out of the request have no bound: +inf.
        for (std::size_t i = 0; i < L.chunks.size(); ++i)
            if (!done[i])
                G.for_each_point(L.chunks[i].cycle, L.chunks[i].box, [&](int64_t x, int64_t y, int64_t z) {
                    errors[G.index(x, y, z)] = std::numeric_limits<float>::infinity();
                });
        out.errors = std::move(errors);
    }
    restore_metadata(field, L.metadata);
    out.field = std::move(field);
    return out;
}

Expected<Volume> decode_volume(tlod::ContainerReader& r, const std::function<void(uint64_t, uint64_t)>& progress) {
    HtDecodeRequest req;
    req.errors = false;
    req.progress = progress;
    auto d = decode_ht(r, req);
    if (!d) return d.failure();
    Volume& f = d->field;
    const Dims src = d->layout.metadata.dims;
    if (f.dims == src) return std::move(f);
    return capture([&] { return crop_volume(f, src); });  // a padded HT: the data's corner of the cube
}

HtModel load_ht_model(const std::string& path) {
    auto r = tlod::ContainerReader::open(path).take();
    HtDecoded d = decode_ht(r).take();
    return HtModel::from_parts(std::move(d.field), d.layout.domain, std::move(d.errors), d.layout.max_error);
}

bool is_tlod_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    char m[8] = {};
    if (!in.read(m, 8)) return false;
    return std::memcmp(m, tlod::kMagic, 8) == 0;
}

}  // namespace tetlod
