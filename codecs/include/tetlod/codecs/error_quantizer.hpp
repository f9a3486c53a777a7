#pragma once
// The error quantizer shared by the HT and MT sections (spec/tlod-format.md §8):
// a float32 error bound kept as a 16-bit code, rounded upward so a stored bound
// is never below the true one.
#include <algorithm>
#include <bit>
#include <cstdint>

namespace tetlod {

inline uint32_t max_error_code(int mantissa_bits) { return 0xFFu << mantissa_bits; }

/// Spec §8: float32 error -> 16-bit code, rounding up (NaN and +inf give the
/// +inf code; negative values and -0 give 0). Always inlined: the error coders
/// call it once per diamond, and GCC kept it out of line there.
[[gnu::always_inline]] inline uint16_t quantize_error(float error, int mantissa_bits) {
    const uint32_t bits = std::bit_cast<uint32_t>(error);
    if ((bits & 0x7FFFFFFFu) >= 0x7F800000u) {  // NaN or an infinity
        if (bits == 0xFF800000u) return 0;      // -inf: a negative value
        return uint16_t(max_error_code(mantissa_bits));
    }
    if (!(error > 0.0f)) return 0;
    const int shift = 23 - mantissa_bits;
    const uint32_t q = (bits + ((uint32_t{1} << shift) - 1)) >> shift;
    return uint16_t(std::min(q, max_error_code(mantissa_bits)));
}
/// Spec §8: code -> float32 bound (exact). Precondition: code <= max_error_code(m).
inline float dequantize_error(uint16_t code, int mantissa_bits) {
    return std::bit_cast<float>(uint32_t(code) << (23 - mantissa_bits));
}

}  // namespace tetlod
