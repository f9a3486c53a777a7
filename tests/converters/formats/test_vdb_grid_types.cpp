// Value types come back as they went in: a grid of every type the VDB reader
// accepts (Float, Double, Int32, Int64, Bool; integer data in a FloatGrid with
// "original_dtype"), made here with the OpenVDB API itself, goes through
// read_vdb/write_vdb and through `tetlod convert` + `tetlod decode`, and the
// written file is opened with OpenVDB: same grid type, same values.
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <cstdlib>
#include <functional>

#include "format_test_util.hpp"
#include "tetlod/converters/vdb.hpp"

using namespace tetlod;
using namespace tetlod::test;

namespace {

constexpr int kN = 5;  // kN^3 voxels, all active (dims_xyz not needed)

struct GridCase {
    std::string name;       // also the grid name and the file stem
    std::string vdb_type;   // GridBase::valueType() expected back
    std::function<openvdb::GridBase::Ptr()> make;
    ValueType read_as;      // what read_vdb gives
};

// Value at voxel (x, y, z): distinct, nonzero (so every voxel is active),
// exact in every type used here.
double sample(int x, int y, int z) { return 1 + x + kN * (y + kN * z); }

template <class GridT>
openvdb::GridBase::Ptr make_grid(const std::function<typename GridT::ValueType(double)>& conv,
                                 const char* original_dtype = nullptr) {
    auto g = GridT::create(typename GridT::ValueType(0));
    auto acc = g->getAccessor();
    for (int z = 0; z < kN; ++z)
        for (int y = 0; y < kN; ++y)
            for (int x = 0; x < kN; ++x) acc.setValue(openvdb::Coord(x, y, z), conv(sample(x, y, z)));
    if (original_dtype) g->insertMeta("original_dtype", openvdb::StringMetadata(original_dtype));
    return g;
}

std::vector<GridCase> cases() {
    return {
        {"f", "float", [] { return make_grid<openvdb::FloatGrid>([](double v) { return float(v) + 0.25f; }); },
         ValueType::F32},
        {"f_as_u8", "float",
         [] { return make_grid<openvdb::FloatGrid>([](double v) { return float(v); }, "uint8"); }, ValueType::U8},
        {"d", "double", [] { return make_grid<openvdb::DoubleGrid>([](double v) { return v / 3; }); },
         ValueType::F64},
        {"d_as_i16", "double",
         [] { return make_grid<openvdb::DoubleGrid>([](double v) { return -v; }, "int16"); }, ValueType::I16},
        {"i32", "int32", [] { return make_grid<openvdb::Int32Grid>([](double v) { return int32_t(v) * -1000; }); },
         ValueType::I32},
        {"i64", "int64",
         [] { return make_grid<openvdb::Int64Grid>([](double v) { return int64_t(v) * 100000; }); },
         ValueType::I32},
        {"i64_u32", "int64",
         [] { return make_grid<openvdb::Int64Grid>([](double v) { return int64_t(v) + 3000000000LL; }); },
         ValueType::U32},
        {"b", "bool", [] { return make_grid<openvdb::BoolGrid>([](double v) { return int(v) % 2 == 1; }); },
         ValueType::U8},
    };
}

openvdb::GridBase::Ptr read_only_grid(const std::string& path) {
    openvdb::io::File f(path);
    f.open();
    auto grids = f.getGrids();
    f.close();
    EXPECT_EQ(grids->size(), 1u) << path;
    return grids->empty() ? nullptr : (*grids)[0];
}

template <class GridT>
void expect_same_values(const openvdb::GridBase::Ptr& a, const openvdb::GridBase::Ptr& b) {
    auto ga = openvdb::gridConstPtrCast<GridT>(a);
    auto gb = openvdb::gridConstPtrCast<GridT>(b);
    ASSERT_TRUE(ga && gb);
    auto aa = ga->getConstAccessor();
    auto ab = gb->getConstAccessor();
    for (int z = 0; z < kN; ++z)
        for (int y = 0; y < kN; ++y)
            for (int x = 0; x < kN; ++x) {
                const openvdb::Coord c(x, y, z);
                ASSERT_EQ(aa.getValue(c), ab.getValue(c)) << x << "," << y << "," << z;
            }
}

void expect_same_grid(const openvdb::GridBase::Ptr& in, const std::string& path, const std::string& type) {
    auto out = read_only_grid(path);
    ASSERT_TRUE(out);
    EXPECT_EQ(out->valueType(), type) << path;
    if (out->valueType() != in->valueType()) return;
    if (type == "float") expect_same_values<openvdb::FloatGrid>(in, out);
    if (type == "double") expect_same_values<openvdb::DoubleGrid>(in, out);
    if (type == "int32") expect_same_values<openvdb::Int32Grid>(in, out);
    if (type == "int64") expect_same_values<openvdb::Int64Grid>(in, out);
    if (type == "bool") expect_same_values<openvdb::BoolGrid>(in, out);
}

}  // namespace

TEST(VdbGridTypes, EveryGridTypeIsWrittenBackAsItWasRead) {
    openvdb::initialize();
    const std::string dir = tmp_dir("vdb_types_lib");
    for (const auto& c : cases()) {
        SCOPED_TRACE(c.name);
        auto grid = c.make();
        grid->setName(c.name);
        openvdb::io::File(dir + "/" + c.name + ".vdb").write({grid});
        const Volume v = read_vdb(dir + "/" + c.name + ".vdb");
        EXPECT_EQ(v.type, c.read_as);
        write_vdb(v, dir + "/" + c.name + "_back.vdb");
        expect_same_grid(grid, dir + "/" + c.name + "_back.vdb", c.vdb_type);
        // And the value type read back is the one read first.
        EXPECT_EQ(read_vdb(dir + "/" + c.name + "_back.vdb").type, c.read_as);
    }
}

TEST(VdbGridTypes, ConvertThenDecodeKeepsTheGridType) {
    openvdb::initialize();
    const std::string dir = tmp_dir("vdb_types_cli");
    for (const auto& c : cases()) {
        SCOPED_TRACE(c.name);
        auto grid = c.make();
        grid->setName(c.name);
        const std::string in = dir + "/" + c.name + ".vdb", tlod = dir + "/" + c.name + ".tlod",
                          back = dir + "/" + c.name + "_decoded.vdb";
        openvdb::io::File(in).write({grid});
        std::filesystem::remove(tlod);
        std::filesystem::remove(back);
        const std::string cli = std::string("'") + TETLOD_CLI_PATH + "' ";
        ASSERT_EQ(std::system((cli + "convert '" + in + "' '" + tlod + "' >/dev/null").c_str()), 0);
        ASSERT_EQ(std::system((cli + "decode '" + tlod + "' '" + back + "' >/dev/null").c_str()), 0);
        expect_same_grid(grid, back, c.vdb_type);
    }
}

TEST(VdbGridTypes, AGridTypeThatCannotHoldTheValuesIsNotUsed) {
    // A volume claiming to come from a BoolGrid but holding 2: written as the
    // default Int32Grid, values intact.
    const std::string dir = tmp_dir("vdb_types_fallback");
    Volume v = Volume::allocate({3, 3, 3}, ValueType::U8);
    v.as<uint8_t>()[5] = 2;
    v.metadata["vdb:grid_type"] = "bool";
    write_vdb(v, dir + "/v.vdb");
    openvdb::initialize();
    EXPECT_EQ(read_only_grid(dir + "/v.vdb")->valueType(), "int32");
    expect_same_samples(v, read_vdb(dir + "/v.vdb"));
    v.metadata["vdb:grid_type"] = "float";  // f64 values do not fit a float grid
    Volume d = Volume::allocate({3, 3, 3}, ValueType::F64);
    d.metadata = v.metadata;
    d.as<double>()[1] = 0.1;
    write_vdb(d, dir + "/d.vdb");
    EXPECT_EQ(read_only_grid(dir + "/d.vdb")->valueType(), "double");
    expect_same_samples(d, read_vdb(dir + "/d.vdb"));
}
