#include "tetlod/core/value_type.hpp"

#include <algorithm>
#include <cctype>

namespace tetlod {

std::size_t value_size(ValueType t) {
    return dispatch_value_type(t, [](auto v) { return sizeof(v); });
}

bool is_float(ValueType t) { return t == ValueType::F32 || t == ValueType::F64; }

bool is_signed(ValueType t) {
    return t == ValueType::I8 || t == ValueType::I16 || t == ValueType::I32 || is_float(t);
}

const char* value_type_name(ValueType t) {
    switch (t) {
        case ValueType::U8: return "u8";
        case ValueType::I8: return "i8";
        case ValueType::U16: return "u16";
        case ValueType::I16: return "i16";
        case ValueType::U32: return "u32";
        case ValueType::I32: return "i32";
        case ValueType::F32: return "f32";
        case ValueType::F64: return "f64";
    }
    return "?";
}

std::optional<ValueType> parse_value_type(std::string_view s) {
    std::string k(s);
    std::transform(k.begin(), k.end(), k.begin(), [](unsigned char c) { return std::tolower(c); });
    struct Name { const char* name; ValueType t; };
    static const Name names[] = {
        {"u8", ValueType::U8},    {"uint8", ValueType::U8},    {"uchar", ValueType::U8},
        {"i8", ValueType::I8},    {"int8", ValueType::I8},     {"char", ValueType::I8},
        {"u16", ValueType::U16},  {"uint16", ValueType::U16},  {"ushort", ValueType::U16},
        {"i16", ValueType::I16},  {"int16", ValueType::I16},   {"short", ValueType::I16},
        {"u32", ValueType::U32},  {"uint32", ValueType::U32},  {"uint", ValueType::U32},
        {"i32", ValueType::I32},  {"int32", ValueType::I32},   {"int", ValueType::I32},
        {"f32", ValueType::F32},  {"float32", ValueType::F32}, {"float", ValueType::F32},
        {"f64", ValueType::F64},  {"float64", ValueType::F64}, {"double", ValueType::F64},
    };
    for (const auto& n : names)
        if (k == n.name) return n.t;
    return std::nullopt;
}

}  // namespace tetlod
