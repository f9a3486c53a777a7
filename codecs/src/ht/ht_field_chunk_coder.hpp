#pragma once
// Residual coding 2, field chunks (spec §7.3-§7.5): residuals of the prediction
// through the adaptive range coder.

#include "ht_prediction.hpp"

namespace tetlod::ht_detail {

struct FieldModels {
    rc::IntModel m[4][16];
};

template <class T>
std::vector<std::byte> encode_field_chunk_v2(const Geometry& G, const T* v, const HtChunk& c) {
    using D = Dom<T>;
    constexpr int W = D::W;
    std::vector<std::byte> out;
    if (c.points == 0) return out;
    auto models = std::make_unique<FieldModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    prefetch_chunk(G, v, c.cycle, c.box, 1);
    rc::Encoder enc(out);
    for_each_point_v2(G, c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z, int cls) {
        const int64_t idx = G.index(x, y, z);
        const Prediction pr = predict_point(G, v, F, c.cycle, cls, x, y, z, idx);
        const int64_t s = lat.slot(x, y, z);
        const uint64_t act = pr.spread + 2 * lat.neighbour_mean(s);
        const auto r = typename D::S(typename D::U(uint64_t(D::get(v[idx])) - uint64_t(pr.p)));
        const bool neg = r < 0;
        const uint64_t mag = neg ? uint64_t(0) - uint64_t(int64_t(r)) : uint64_t(r);
        rc::encode_int(enc, models->m[cls][activity_bucket(act)], mag, neg, W);
        lat.set(s, mag);
    });
    enc.finish();
    return out;
}

/// False on a malformed stream.
template <class T>
bool decode_field_chunk_v2(const Geometry& G, T* v, const HtChunk& c, std::span<const std::byte> in) {
    using D = Dom<T>;
    constexpr int W = D::W;
    if (c.points == 0) return in.empty();
    auto models = std::make_unique<FieldModels>();
    thread_local std::vector<uint32_t> storage;
    ChunkLattice lat(c.cycle, c.box, storage);
    const ChunkFrame F(G, c.cycle, c.box);
    rc::Decoder dec(in.data(), in.size());
    for_each_point_v2(G, c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z, int cls) {
        if (dec.overrun()) return;  // a valid stream never reads past its end: stop early
        const int64_t idx = G.index(x, y, z);
        const Prediction pr = predict_point(G, v, F, c.cycle, cls, x, y, z, idx);
        const int64_t s = lat.slot(x, y, z);
        const uint64_t act = pr.spread + 2 * lat.neighbour_mean(s);
        uint64_t mag;
        bool neg;
        rc::decode_int(dec, models->m[cls][activity_bucket(act)], mag, neg, W);
        const typename D::U r = neg ? typename D::U(uint64_t(0) - mag) : typename D::U(mag);
        v[idx] = D::put(typename D::U(uint64_t(pr.p) + uint64_t(r)));
        lat.set(s, mag);
    });
    return !dec.bad_end();
}

}  // namespace tetlod::ht_detail
