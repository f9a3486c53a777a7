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
#include "ht_chunk_modes.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tetlod/codecs/lossy_field.hpp"

namespace tetlod::ht_detail {

inline std::vector<std::byte> ht_header_bytes(const HtDomain& d, int g, int m) {
    std::vector<std::byte> h;
    tlod::put_u8(h, uint8_t(d.k));
    tlod::put_u8(h, d.padded ? 1 : 0);
    tlod::put_u8(h, uint8_t(g));
    tlod::put_u8(h, uint8_t(m));
    tlod::put_u8(h, kPredictorNeighbours);
    tlod::put_u8(h, 3);  // Residual_Coding 3: a mode per chunk section (§6.4)
    tlod::put_u16(h, 0);
    for (int a = 0; a < 3; ++a) tlod::put_u32(h, uint32_t(d.box_max[a]));
    tlod::put_u32(h, 0);
    return h;
}

/// Informative summary of the stored error bounds (spec §5.3), so `info`
/// reports them without decoding any chunk: the largest finite stored bound
/// and the number of always-split diamonds.
struct ErrorSummary {
    explicit ErrorSummary(int m = 0)
        : m_(m), limit_(dequantize_error(uint16_t(max_error_code(m) - 1), m)) {}

    /// The stored bound of `error` is dequantize(quantize(error)): infinite
    /// above the largest finite code, and quantize is monotone, so the largest
    /// finite stored bound is the stored bound of the largest error below it.
    void add(float error) {
        if (!(error <= limit_)) ++always_split;  // NaN too
        else if (error > raw_max_) raw_max_ = error;
    }
    void merge(const ErrorSummary& o) {
        raw_max_ = std::max(raw_max_, o.raw_max_);
        always_split += o.always_split;
    }
    /// The largest error below the limit (merge_raw: another part's).
    float raw_max() const { return raw_max_; }
    void merge_raw(float raw_max, uint64_t always) {
        raw_max_ = std::max(raw_max_, raw_max);
        always_split += always;
    }
    float max_finite() const { return dequantize_error(quantize_error(raw_max_, m_), m_); }
    void write_to(tlod::Metadata& md) const {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.9g", double(max_finite()));
        md.format_keys[tlod::kKeyHtErrorMax] = buf;
        md.format_keys[tlod::kKeyHtAlwaysSplit] = std::to_string(always_split);
    }

    uint64_t always_split = 0;

private:
    int m_;
    float limit_;
    float raw_max_ = 0;
};

/// The chunk modes an encode with `o` may choose: the one mapping, so whole,
/// streamed and distributed encodes code alike.
inline ChunkModeChoice chunk_mode_choice(const HtEncodeOptions& o) {
    ChunkModeChoice c;
    c.forced = o.chunk_mode;
    c.zstd_level = o.chunk_zstd_level;
    c.max_error = o.max_error;
    c.range_2d = o.range_2d;
    c.fast_decode = o.fast_decode;
    c.range_exp = o.range_exp;
    return c;
}

/// The sections an HT container starts with (METADATA with the error
/// summary, HT_HEADER), added to `w` with its features: shared by the
/// streaming encoder and the distributed layout so both write the same head.
/// The features and the field.max_error key of a container written with `o`
/// (spec §5.1: LOSSY and the key together).
inline uint64_t ht_features(tlod::Metadata& md, const HtEncodeOptions& o) {
    // Every HT writer asks for its features here first: the one place to refuse
    // a 3.7 chunk mode in a file whose full table is meant for older readers.
    if ((o.fast_decode || o.chunk_mode == 6) && o.table != tlod::TableLayout::compact)
        throw Error(ErrorCode::InvalidArgument,
                    "static chunks (format 3.7) need the compact table: the full one is for readers older than 3.2");
    if (!(o.max_error > 0)) return tlod::kFeatureHt;
    if (!std::isfinite(o.max_error)) throw Error(ErrorCode::InvalidArgument, "lossy max error must be finite");
    md.format_keys[tlod::kKeyFieldMaxError] = format_max_error(o.max_error);
    return tlod::kFeatureHt | tlod::kFeatureLossy;
}

inline void add_ht_leading_sections(tlod::ContainerWriter& w, const HtDomain& d, tlod::Metadata md,
                                    const ErrorSummary& errors, const HtEncodeOptions& o) {
    errors.write_to(md);
    w.set_features(ht_features(md, o));
    w.set_table(o.table);
    w.add(tlod::kSectionMetadata, tlod::kSectionCritical, 0, 0, tlod::serialize_metadata(md), o.zstd_level);
    const auto hh = ht_header_bytes(d, o.brick_log2, o.error_mantissa_bits);
    w.add_stored(tlod::kSectionHtHeader, tlod::kSectionCritical, 0, 0, hh, hh.size());
}

}  // namespace tetlod::ht_detail
