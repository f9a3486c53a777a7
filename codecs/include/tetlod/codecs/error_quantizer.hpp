#pragma once
// The error quantizer shared by the HT and MT sections (spec/tlod-format.md §8):
// a float32 error bound kept as a 16-bit code, rounded upward so a stored bound
// is never below the true one.
#include <cstdint>

namespace tetlod {

/// Spec §8: float32 error -> 16-bit code, rounding up (NaN and +inf give the
/// +inf code; negative values and -0 give 0).
uint16_t quantize_error(float error, int mantissa_bits);
/// Spec §8: code -> float32 bound (exact). Precondition: code <= max_error_code(m).
float dequantize_error(uint16_t code, int mantissa_bits);
inline uint32_t max_error_code(int mantissa_bits) { return 0xFFu << mantissa_bits; }

}  // namespace tetlod
