#pragma once
// Compact serialization of the MT (docs/mt.md §5):
// per grid point removed by the decimation, in raster order of that point w: the
// survivor offset s - w, the node label, the error quantized upward to 16 bits,
// the star size, and the split mask coded as a cut plus exceptions over the
// direction-ordered star. Streams are kept apart (structure of arrays) and the
// whole payload is one zstd frame. The field may be included (raw samples) or
// supplied by the caller on decode (e.g. from the container's field sections).
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

/// The coding encode_mt writes by default, and the newest decode_mt reads
/// (it reads codings 1 to 3; spec/tlod-format.md §10.2).
inline constexpr uint16_t kMtCodecVersion = 3;

struct MtEncodeOptions {
    /// zstd level of every stream's frame, but see large_stream_zstd_level.
    int zstd_level = 19;
    /// Streams of more than large_stream_bytes raw are compressed at
    /// min(zstd_level, this) (0: at zstd_level). Level 19 costs about 2 s of CPU
    /// per MB of stream and gains 1-19 % over 12 (median about 6 %): on a 257^3
    /// volume its 11 streams (160 MB raw) took 278 CPU s at 19 and 34 s at 12,
    /// for 5.4 % more bytes (docs/mt.md §5, "zstd level of the streams").
    int large_stream_zstd_level = 12;
    std::size_t large_stream_bytes = std::size_t(1) << 20;
    /// Mantissa bits of the upward error quantizer (0..7, as the HT's, spec §8).
    int error_mantissa_bits = 7;
    /// Store the field samples too (otherwise decode_mt needs the field).
    bool include_field = false;
    /// A lossy container's E (spec §5.1; 0: lossless). The model was built on the
    /// stored field f', within E of the original: every update's error is stored as
    /// bound_against_original(error, E), so the bounds hold against the original
    /// for any reader (|L_T - f| <= |L_T - f'| + E).
    double field_error = 0;
    /// MT_Coding to write: 3 (default, format 3.4) or 2, which format 3.1-3.3
    /// readers also read (12 and 11 streams, spec §10.2). Anything else throws.
    int coding = kMtCodecVersion;
};

/// Encodes the model. Deterministic: the same model gives the same bytes (single-
/// threaded zstd at a fixed level). Errors are rounded up, so a decoded model may
/// refine slightly more than the original but never violates a bound.
std::vector<uint8_t> encode_mt(const MtModel& model, const MtEncodeOptions& options = {});

/// Decodes bytes from encode_mt. Safe on untrusted input: every count is checked
/// against the bytes that remain before allocating, never reads out of bounds,
/// returns Truncated / BadMagic / UnsupportedVersion / CorruptData / TooLarge
/// failures instead of throwing. `field` supplies the samples when the bytes do not
/// include them (its dims and type must match the header); ignored otherwise.
Expected<MtModel> decode_mt(std::span<const uint8_t> bytes, const Volume* field = nullptr);

}  // namespace tetlod
