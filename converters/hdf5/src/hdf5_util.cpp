// Small HDF5 helpers. See hdf5_util.hpp.
#include "hdf5_util.hpp"

#include <charconv>

namespace tetlod::hdf5_detail {

void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

std::string hdf5_error_text() {
    std::string text;
    H5Ewalk2(
        H5E_DEFAULT, H5E_WALK_UPWARD,
        [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
            auto* s = static_cast<std::string*>(data);
            if (n == 0 && e && e->desc) *s = e->desc;
            return 0;
        },
        &text);
    H5Eclear2(H5E_DEFAULT);
    return text.empty() ? "HDF5 library error" : text;
}

std::string num_text(double v) {
    char buf[64];
    auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
    (void)ec;
    return std::string(buf, p);
}

std::string name_of(const std::string& file, const std::string& dataset) { return "'" + file + ":" + dataset + "'"; }

std::string normalize_dataset(const std::string& d) {
    if (d.empty()) return "/volume";
    return d[0] == '/' ? d : "/" + d;
}

hid_t native_type(ValueType t) {
    switch (t) {
        case ValueType::U8: return H5T_NATIVE_UINT8;
        case ValueType::I8: return H5T_NATIVE_INT8;
        case ValueType::U16: return H5T_NATIVE_UINT16;
        case ValueType::I16: return H5T_NATIVE_INT16;
        case ValueType::U32: return H5T_NATIVE_UINT32;
        case ValueType::I32: return H5T_NATIVE_INT32;
        case ValueType::F32: return H5T_NATIVE_FLOAT;
        case ValueType::F64: return H5T_NATIVE_DOUBLE;
    }
    return H5T_NATIVE_UINT8;
}

hid_t file_type(ValueType t, Endian e) {
    const bool be = e == Endian::Big;
    switch (t) {
        case ValueType::U8: return be ? H5T_STD_U8BE : H5T_STD_U8LE;
        case ValueType::I8: return be ? H5T_STD_I8BE : H5T_STD_I8LE;
        case ValueType::U16: return be ? H5T_STD_U16BE : H5T_STD_U16LE;
        case ValueType::I16: return be ? H5T_STD_I16BE : H5T_STD_I16LE;
        case ValueType::U32: return be ? H5T_STD_U32BE : H5T_STD_U32LE;
        case ValueType::I32: return be ? H5T_STD_I32BE : H5T_STD_I32LE;
        case ValueType::F32: return be ? H5T_IEEE_F32BE : H5T_IEEE_F32LE;
        case ValueType::F64: return be ? H5T_IEEE_F64BE : H5T_IEEE_F64LE;
    }
    return H5T_STD_U8LE;
}

const std::set<std::string>& structural_attributes() {
    static const std::set<std::string> s = {"spacing", "spacing_order", "origin",  "axis_order",
                                            "dims_xyz", "field_name",   "units"};
    return s;
}

}  // namespace tetlod::hdf5_detail
