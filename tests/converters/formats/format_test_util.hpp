#pragma once
// Helpers for the converter tests: volumes that exercise every value type
// (extremes, negative zero, NaN), an independent raw-file reader, and checks
// that a failed operation left nothing behind.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::test {

inline const ValueType kAllTypes[] = {ValueType::U8,  ValueType::I8,  ValueType::U16, ValueType::I16,
                                      ValueType::U32, ValueType::I32, ValueType::F32, ValueType::F64};

inline std::string tmp_dir(const std::string& sub) {
    std::filesystem::path p = std::filesystem::path(TETLOD_TEST_TMP) / sub;
    std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
    return p.string();
}

/// A whole file as bytes, and bytes written as a whole file (for crafted inputs).
inline std::string slurp(const std::string& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}
inline void spit(const std::string& p, const std::string& bytes) {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string data_path(const std::string& name) { return std::string(TETLOD_SHARED_DATA) + "/" + name; }

/// A 5x4x3 volume whose values cover the type's extremes, zero, and for floats
/// -0.0, NaN, infinities and denormals; plus geometry and metadata.
inline Volume make_volume(ValueType t, Dims dims = {5, 4, 3}) {
    Volume v = Volume::allocate(dims, t);
    dispatch_value_type(t, [&](auto z) {
        using T = decltype(z);
        using L = std::numeric_limits<T>;
        std::vector<T> special = {L::lowest(), L::max(), T(0), T(1), T(L::max() / 3)};
        if constexpr (std::is_floating_point_v<T>) {
            special.insert(special.end(), {T(-0.0), L::quiet_NaN(), L::infinity(), -L::infinity(), L::denorm_min(),
                                           T(0.1), T(-1234.5)});
        } else if constexpr (std::is_signed_v<T>) {
            special.push_back(T(-1));
        }
        T* p = v.as<T>();
        for (int64_t i = 0; i < v.count(); ++i)
            p[i] = i < static_cast<int64_t>(special.size()) ? special[i] : static_cast<T>((i * 37) % 101);
    });
    v.spacing = {0.5, 1.25, 3.0};
    v.origin = {-10.5, 0.0, 7.25};
    v.field_name = "density";
    v.units = "g/cm^3";
    v.metadata["source"] = "tetlod test";
    v.metadata["comment"] = "two words, \"quoted\"";
    return v;
}

inline void expect_same_samples(const Volume& a, const Volume& b) {
    ASSERT_EQ(a.dims, b.dims);
    ASSERT_EQ(a.type, b.type) << value_type_name(a.type) << " vs " << value_type_name(b.type);
    ASSERT_EQ(a.data.size(), b.data.size());
    EXPECT_TRUE(std::memcmp(a.data.data(), b.data.data(), a.data.size()) == 0) << "samples differ";
}

inline void expect_same_geometry(const Volume& a, const Volume& b) {
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(a.spacing[i], b.spacing[i]) << "spacing " << i;
        EXPECT_EQ(a.origin[i], b.origin[i]) << "origin " << i;
    }
}

/// Reads a headerless little-endian raw file of the shared data by definition.
inline std::vector<std::byte> read_file_bytes(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::vector<char> c((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::vector<std::byte> b(c.size());
    std::memcpy(b.data(), c.data(), c.size());
    return b;
}

inline void write_text(const std::string& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary);
    f << text;
}

inline void write_bytes(const std::string& path, const void* data, std::size_t n, std::ios::openmode extra = {}) {
    std::ofstream f(path, std::ios::binary | extra);
    f.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
}

inline std::size_t files_in(const std::string& dir) {
    std::size_t n = 0;
    for (auto& e : std::filesystem::directory_iterator(dir)) (void)e, ++n;
    return n;
}

/// Runs `f`, expects a tetlod::Error with `code` whose message contains every
/// string of `needles`.
template <class F>
void expect_error(F&& f, ErrorCode code, std::vector<std::string> needles) {
    try {
        f();
        ADD_FAILURE() << "expected an error (" << error_code_name(code) << ")";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), code) << e.what();
        for (const auto& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
    }
}

}  // namespace tetlod::test
