#pragma once
// Scalar value types a volume may hold. Values are exactly representable in
// double for every type here, which lets generic code use double safely.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tetlod {

enum class ValueType : uint8_t { U8 = 1, I8 = 2, U16 = 3, I16 = 4, U32 = 5, I32 = 6, F32 = 7, F64 = 8 };

std::size_t value_size(ValueType t);
bool is_float(ValueType t);
bool is_signed(ValueType t);
/// Short name as on the command line: u8, i8, u16, i16, u32, i32, f32, f64.
const char* value_type_name(ValueType t);
/// Accepts the short names and the long spellings used in file names
/// (uint8, int16, float32, float, double, ...). Case-insensitive.
std::optional<ValueType> parse_value_type(std::string_view s);

/// Calls f(T{}) with the C++ type behind t.
template <class F>
decltype(auto) dispatch_value_type(ValueType t, F&& f) {
    switch (t) {
        case ValueType::U8: return f(uint8_t{});
        case ValueType::I8: return f(int8_t{});
        case ValueType::U16: return f(uint16_t{});
        case ValueType::I16: return f(int16_t{});
        case ValueType::U32: return f(uint32_t{});
        case ValueType::I32: return f(int32_t{});
        case ValueType::F32: return f(float{});
        case ValueType::F64: break;
    }
    return f(double{});
}

template <class T> constexpr ValueType value_type_of();
template <> constexpr ValueType value_type_of<uint8_t>() { return ValueType::U8; }
template <> constexpr ValueType value_type_of<int8_t>() { return ValueType::I8; }
template <> constexpr ValueType value_type_of<uint16_t>() { return ValueType::U16; }
template <> constexpr ValueType value_type_of<int16_t>() { return ValueType::I16; }
template <> constexpr ValueType value_type_of<uint32_t>() { return ValueType::U32; }
template <> constexpr ValueType value_type_of<int32_t>() { return ValueType::I32; }
template <> constexpr ValueType value_type_of<float>() { return ValueType::F32; }
template <> constexpr ValueType value_type_of<double>() { return ValueType::F64; }

}  // namespace tetlod
