#pragma once
// Deterministic test volumes of any dims and value type, a padding reference, and a
// tiny raw-file reader (x fastest, little-endian) for the real datasets (TETLOD_DATA_DIR).
#include <cstdint>
#include <optional>
#include <string>

#include "tetlod/core/volume.hpp"

namespace tetlod::test {

enum class Field {
    Smooth,    // sum of sines
    Noisy,     // hash-based pseudo-random
    Plateau,   // a few constant steps/terraces: lots of ties, many zero errors
    Constant,
};
const char* field_name(Field f);

/// Values are mapped to a type-dependent range (u8: 0..255, i16: -3000..3000,
/// u16: 0..60000, i32: -10^6..10^6, u32: 0..10^6, i8: -100..100, f32/f64: -1..1 raw) and
/// rounded for integer types. Same (dims, type, field, seed) -> same bytes.
Volume make_volume(Dims dims, ValueType type, Field field, uint32_t seed = 1);

/// Extends v to the enclosing (2^k+1)^3 cube (2^k >= max dim - 1); each new point takes
/// the value of the nearest data point (clamp each coordinate).
Volume pad_to_cube(const Volume& v);

/// Reads a headerless raw file; nullopt if missing or of the wrong size.
std::optional<Volume> read_raw(const std::string& path, Dims dims, ValueType type);

/// Path of a real dataset (directory TETLOD_SHARED_DATA, defined by tetlod_test targets
/// from TETLOD_DATA_DIR; relative to the working directory when unset).
inline std::string shared_data_path(const std::string& name) {
#ifdef TETLOD_SHARED_DATA
    return std::string(TETLOD_SHARED_DATA) + "/" + name;
#else
    return name;
#endif
}

}  // namespace tetlod::test
