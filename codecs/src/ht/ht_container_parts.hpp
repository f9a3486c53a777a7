#pragma once
// Pieces of an HT container both encoders (in memory: ht_encode.cpp; plane by
// plane: ht_stream_encode.cpp) write identically: the HT_HEADER bytes and the
// METADATA summary of the stored error bounds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ht_chunk_geometry.hpp"
#include "tetlod/format/metadata.hpp"

namespace tetlod::ht_detail {

inline std::vector<std::byte> ht_header_bytes(const HtDomain& d, int g, int m) {
    std::vector<std::byte> h;
    tlod::put_u8(h, uint8_t(d.k));
    tlod::put_u8(h, d.padded ? 1 : 0);
    tlod::put_u8(h, uint8_t(g));
    tlod::put_u8(h, uint8_t(m));
    tlod::put_u8(h, kPredictorNeighbours);
    tlod::put_u8(h, kResidualRangeCoder);
    tlod::put_u16(h, 0);
    for (int a = 0; a < 3; ++a) tlod::put_u32(h, uint32_t(d.box_max[a]));
    tlod::put_u32(h, 0);
    return h;
}

/// Informative summary of the stored error bounds (spec §5.3), so `info`
/// reports them without decoding any chunk: the largest finite stored bound
/// and the number of always-split diamonds.
struct ErrorSummary {
    float max_finite = 0;
    uint64_t always_split = 0;

    void add(float error, int m) {
        const float q = dequantize_error(quantize_error(error, m), m);
        if (std::isinf(q)) ++always_split;
        else max_finite = std::max(max_finite, q);
    }
    void merge(const ErrorSummary& o) {
        max_finite = std::max(max_finite, o.max_finite);
        always_split += o.always_split;
    }
    void write_to(tlod::Metadata& md) const {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.9g", double(max_finite));
        md.format_keys[tlod::kKeyHtErrorMax] = buf;
        md.format_keys[tlod::kKeyHtAlwaysSplit] = std::to_string(always_split);
    }
};

}  // namespace tetlod::ht_detail
