#include "tetlod/codecs/error_quantizer.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace tetlod {

uint16_t quantize_error(float error, int m) {
    const int shift = 23 - m;
    if (std::isnan(error) || error == std::numeric_limits<float>::infinity())
        return uint16_t(max_error_code(m));
    if (!(error > 0.0f)) return 0;
    const uint32_t bits = std::bit_cast<uint32_t>(error);
    const uint32_t q = (bits + ((uint32_t{1} << shift) - 1)) >> shift;
    return uint16_t(std::min(q, max_error_code(m)));
}

float dequantize_error(uint16_t code, int m) {
    return std::bit_cast<float>(uint32_t(code) << (23 - m));
}

}  // namespace tetlod
