// Built-in sample volumes, checked against their formulas written out again here
// (independently of the implementation) at every grid point.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <numbers>

#include "tetlod/converters/sample_volumes.hpp"
#include "tetlod/core/error.hpp"

using namespace tetlod;

namespace {

double ml_definition(double x, double y, double z) {
    const double pi = std::numbers::pi;
    const double r = std::sqrt(x * x + y * y);
    const double rho = std::cos(2 * pi * 6 * std::cos(pi * r / 2));
    return (1 - std::sin(pi * z / 2) + 0.25 * (1 + rho)) / (2 * 1.25);
}

double grid_coord(int64_t i, int64_t n) { return -1.0 + 2.0 * i / (n - 1); }

}  // namespace

TEST(SampleVolumes, NamesListed) {
    const auto names = sample_volume_names();
    for (const char* n : {"marschner-lobb", "multiscale", "sphere"})
        EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
}

TEST(SampleVolumes, UnknownNameListsKnownOnes) {
    try {
        make_sample_volume("teapot", Dims{4, 4, 4});
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
        const std::string m = e.what();
        EXPECT_NE(m.find("teapot"), std::string::npos) << m;
        for (const auto& n : sample_volume_names()) EXPECT_NE(m.find(n), std::string::npos) << m;
    }
}

TEST(SampleVolumes, MarschnerLobbMatchesDefinitionF64) {
    const Dims d{9, 7, 11};
    const Volume v = make_sample_volume("marschner-lobb", d, ValueType::F64);
    for (int64_t k = 0; k < d.z; ++k)
        for (int64_t j = 0; j < d.y; ++j)
            for (int64_t i = 0; i < d.x; ++i)
                ASSERT_NEAR(
                    v.value(i, j, k),
                    ml_definition(grid_coord(i, d.x), grid_coord(j, d.y), grid_coord(k, d.z)),
                    1e-12)
                    << i << "," << j << "," << k;
}

TEST(SampleVolumes, U8QuantisesOntoFullRange) {
    const Dims d{17, 17, 17};
    const Volume v = make_sample_volume("marschner-lobb", d);
    EXPECT_EQ(v.type, ValueType::U8);
    for (int64_t k = 0; k < d.z; ++k)
        for (int64_t j = 0; j < d.y; ++j)
            for (int64_t i = 0; i < d.x; ++i) {
                const double f =
                    ml_definition(grid_coord(i, d.x), grid_coord(j, d.y), grid_coord(k, d.z));
                ASSERT_NEAR(v.value(i, j, k), f * 255.0, 0.5 + 1e-9);
            }
}

TEST(SampleVolumes, IntegerTypesStayInRange) {
    for (ValueType t :
         {ValueType::I8, ValueType::U16, ValueType::I16, ValueType::U32, ValueType::I32}) {
        const Volume v = make_sample_volume("sphere", Dims{9, 9, 9}, t);
        const auto r = v.range();
        // Corners are f = 0 and the centre f = 1: both ends of the type are used.
        const double lo = t == ValueType::I8    ? -128
                          : t == ValueType::I16 ? -32768
                          : t == ValueType::I32 ? -2147483648.0
                                                : 0;
        const double hi = t == ValueType::I8    ? 127
                          : t == ValueType::U16 ? 65535
                          : t == ValueType::I16 ? 32767
                          : t == ValueType::U32 ? 4294967295.0
                                                : 2147483647.0;
        EXPECT_EQ(r[0], lo) << value_type_name(t);
        EXPECT_EQ(r[1], hi) << value_type_name(t);
    }
}

TEST(SampleVolumes, FieldsLieInUnitRange) {
    for (const auto& name : sample_volume_names()) {
        const Volume v = make_sample_volume(name, Dims{33, 33, 33}, ValueType::F32);
        const auto r = v.range();
        EXPECT_GE(r[0], 0.0) << name;
        EXPECT_LE(r[1], 1.0) << name;
        if (name != "constant") EXPECT_GT(r[1] - r[0], 0.3) << name << " should not be nearly constant";
    }
}

TEST(SampleVolumes, ArchivalCases) {
    const Dims d{65, 65, 65};
    const Volume c = make_sample_volume("constant", d);
    EXPECT_EQ(c.range(), (std::array<double, 2>{128, 128}));  // round(0.5 * 255)

    // sparse: about 99% exact zeros.
    const Volume s = make_sample_volume("sparse", d);
    const auto* p = s.as<uint8_t>();
    const auto zeros = std::count(p, p + s.count(), uint8_t{0});
    EXPECT_GT(double(zeros) / double(s.count()), 0.98);
    EXPECT_LT(double(zeros) / double(s.count()), 0.999);

    // noisy: neighbours differ by the noise, not only by the smooth part.
    const Volume n = make_sample_volume("noisy", d, ValueType::F32);
    double diff = 0;
    for (int64_t i = 0; i + 1 < d.x; ++i) diff += std::abs(n.value(i + 1, 32, 32) - n.value(i, 32, 32));
    EXPECT_GT(diff / double(d.x - 1), 0.03);
}

TEST(SampleVolumes, SphereIsRadial) {
    const Volume v = make_sample_volume("sphere", Dims{5, 5, 5}, ValueType::F64);
    EXPECT_DOUBLE_EQ(v.value(2, 2, 2), 1.0);
    EXPECT_NEAR(v.value(0, 0, 0), 0.0, 1e-15);
    EXPECT_DOUBLE_EQ(v.value(0, 2, 2), v.value(2, 4, 2));  // same distance, same value
    EXPECT_NEAR(v.value(4, 2, 2), 1.0 - 1.0 / std::sqrt(3.0), 1e-15);
}

TEST(SampleVolumes, MultiscaleHasItsNarrowBlob) {
    // The narrow blob at (0.5,-0.55,0.5) is visible only at fine resolution: at
    // 81^3 the grid point nearest to it stands out from its neighbours 2 steps away.
    const Dims d{81, 81, 81};
    const Volume v = make_sample_volume("multiscale", d, ValueType::F64);
    const int64_t i = 60, j = 18, k = 60;  // x = 0.5, y = -0.55, z = 0.5
    EXPECT_GT(v.value(i, j, k) - v.value(i + 2, j, k), 0.05);
}

TEST(SampleVolumes, GeometryAndMetadata) {
    const Volume v = make_sample_volume("multiscale", Dims{5, 9, 3});
    EXPECT_EQ(v.spacing, (Vec3{0.5, 0.25, 1.0}));
    EXPECT_EQ(v.origin, (Vec3{-1.0, -1.0, -1.0}));
    EXPECT_EQ(v.metadata.at("sample"), "multiscale");
    EXPECT_EQ(v.field_name, "multiscale");
}

TEST(SampleVolumes, Deterministic) {
    for (const auto& name : sample_volume_names())
        EXPECT_EQ(make_sample_volume(name, Dims{12, 10, 8}).data,
                  make_sample_volume(name, Dims{12, 10, 8}).data)
            << name;
}

TEST(SampleVolumes, RefusesDegenerateDims) {
    for (Dims d : {Dims{1, 4, 4}, Dims{4, 0, 4}, Dims{4, 4, -3}}) {
        try {
            make_sample_volume("sphere", d);
            FAIL() << "no error";
        } catch (const Error& e) {
            EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
        }
    }
}
