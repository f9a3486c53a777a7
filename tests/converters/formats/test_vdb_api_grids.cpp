// VDB files made with the OpenVDB API itself, read back by tetlod. Both groups
// share this one file because each instantiates OpenVDB's grid templates for
// the same five grid types: compiled once, that costs about two minutes, not
// four (in every build, sanitized ones included).
//
// VdbGridTypes: value types come back as they went in: a grid of every type
// the VDB reader accepts (Float, Double, Int32, Int64, Bool; integer data in a
// FloatGrid with "original_dtype") goes through read_vdb/write_vdb and through
// `tetlod convert` + `tetlod decode`, and the written file is opened with
// OpenVDB: same grid type, same values.
//
// VdbPlanes: open_vdb_planes gives read_vdb's header, type and samples for
// every grid type, sparse grids (background where inactive, active tiles), the
// extent from dims_xyz or the active bounding box, and the type narrowing the
// whole read does (Int64 to 32-bit, "original_dtype"), read in forward,
// backward and shuffled order, isolated or not; a truncated file and a missing
// grid are clean errors naming the file.
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <cstdlib>
#include <functional>

#include "format_test_util.hpp"
#include "support/plane_checks.hpp"
#include "tetlod/converters/vdb.hpp"

using namespace tetlod;
using namespace tetlod::test;

namespace {

// ---- VdbGridTypes: dense kN^3 grids of every type
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

std::vector<GridCase> grid_cases() {
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

// ---- VdbPlanes: sparse grids
void write_grid(const std::string& path, openvdb::GridBase::Ptr g) {
    openvdb::initialize();
    g->setName("g");
    openvdb::GridPtrVec grids{g};
    openvdb::io::File(path).write(grids);
}

// A sparse grid: a diagonal band of active voxels with values v(x, y, z), an
// active 8^3 tile, inactive voxels holding non-background values (which must
// read as the background), background `bg`.
template <class GridT>
openvdb::GridBase::Ptr sparse(typename GridT::ValueType bg,
                              const std::function<typename GridT::ValueType(int, int, int)>& v,
                              const char* original_dtype = nullptr, bool with_dims = true) {
    auto g = GridT::create(bg);
    auto acc = g->getAccessor();
    for (int z = 0; z < 20; ++z)
        for (int y = 0; y < 17; ++y)
            for (int x = 0; x < 23; ++x)
                if ((x + y + z) % 3 == 0)
                    acc.setValue(openvdb::Coord(x, y, z), v(x, y, z));
                else if ((x * y + z) % 7 == 0)
                    acc.setValueOff(openvdb::Coord(x, y, z), v(x, y, z));
    g->tree().addTile(1, openvdb::Coord(8, 8, 8), v(1, 2, 3), true);
    if (with_dims) g->insertMeta("dims_xyz", openvdb::Vec3IMetadata(openvdb::Vec3i(23, 19, 21)));
    if (original_dtype) g->insertMeta("original_dtype", openvdb::StringMetadata(original_dtype));
    return g;
}

void check(const std::string& path, ValueType expected) {
    const Volume whole = read_vdb(path);
    EXPECT_EQ(whole.type, expected);
    for (bool isolated : {true, false}) {
        SCOPED_TRACE(isolated ? "isolated" : "in process");
        VolumeReadOptions o;
        o.isolation.enabled = isolated;
        auto planes = open_vdb_planes(path, o);
        expect_planes_equal_whole(*planes, whole, 9);
    }
}

}  // namespace

TEST(VdbGridTypes, EveryGridTypeIsWrittenBackAsItWasRead) {
    openvdb::initialize();
    const std::string dir = tmp_dir("vdb_types_lib");
    for (const auto& c : grid_cases()) {
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
    for (const auto& c : grid_cases()) {
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

TEST(VdbPlanes, EveryGridTypeSparseGridsAndNarrowingEqualTheWholeRead) {
    const std::string dir = tmp_dir("vdb_planes");
    struct Case {
        const char* name;
        openvdb::GridBase::Ptr grid;
        ValueType expected;
    };
    using openvdb::BoolGrid, openvdb::DoubleGrid, openvdb::FloatGrid, openvdb::Int32Grid,
        openvdb::Int64Grid;
    const Case cases[] = {
        {"f",
         sparse<FloatGrid>(-0.5f, [](int x, int y, int z) { return float(x * 0.25 - y + z * 3); }),
         ValueType::F32},
        {"f_nan",
         sparse<FloatGrid>(std::numeric_limits<float>::quiet_NaN(),
                           [](int x, int, int) { return -0.0f * float(x); }),
         ValueType::F32},
        {"f_u8",
         sparse<FloatGrid>(
             0.f, [](int x, int y, int) { return float((x + y) % 200); }, "uint8"),
         ValueType::U8},
        {"f_u8_no",
         sparse<FloatGrid>(
             0.f, [](int x, int, int) { return float(x) + 0.5f; }, "uint8"),
         ValueType::F32},  // not exact: stays float
        {"d", sparse<DoubleGrid>(7.0, [](int x, int y, int z) { return x / 3.0 + y - z; }),
         ValueType::F64},
        {"i32", sparse<Int32Grid>(-5, [](int x, int y, int z) { return x * 1000 - y * 77 + z; }),
         ValueType::I32},
        {"i64",
         sparse<Int64Grid>(3, [](int x, int y, int z) { return int64_t(x) * 100000 - y - z; }),
         ValueType::I32},
        {"i64_u32", sparse<Int64Grid>(0, [](int x, int, int) { return int64_t(4000000000) + x; }),
         ValueType::U32},
        {"b", sparse<BoolGrid>(false, [](int x, int, int) { return x % 2 == 0; }), ValueType::U8},
        {"bbox",
         sparse<FloatGrid>(
             1.f, [](int x, int, int) { return float(x); }, nullptr, false),
         ValueType::F32},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        const std::string path = dir + "/" + c.name + ".vdb";
        write_grid(path, c.grid);
        check(path, c.expected);
    }
    // Written by tetlod (u16 in a FloatGrid with tetlod_value_type; zeros inactive).
    Volume v = make_volume(ValueType::U16, {9, 8, 7});
    write_vdb(v, dir + "/w.vdb");
    check(dir + "/w.vdb", ValueType::U16);
}

TEST(VdbPlanes, BadFilesAreCleanErrors) {
    const std::string dir = tmp_dir("vdb_planes_bad");
    write_vdb(make_volume(ValueType::F32, {30, 20, 10}), dir + "/v.vdb");
    const std::string bytes = slurp(dir + "/v.vdb");
    spit(dir + "/t.vdb", bytes.substr(0, bytes.size() * 2 / 3));
    for (bool isolated : {true, false}) {
        VolumeReadOptions o;
        o.isolation.enabled = isolated;
        try {
            open_vdb_planes(dir + "/t.vdb", o);
            ADD_FAILURE() << "a truncated file was opened";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("t.vdb"), std::string::npos) << e.what();
        }
    }
    VolumeReadOptions o;
    o.grid = "nope";
    expect_error([&] { open_vdb_planes(dir + "/v.vdb", o); }, ErrorCode::NotFound,
                 {"v.vdb", "nope"});
}

TEST(VdbPlanes, WriterFedPlanesWritesTheWholeWritersGrid) {
    const std::string dir = tmp_dir("vdb_planes_write");
    for (ValueType t : kAllTypes) {
        SCOPED_TRACE(value_type_name(t));
        Volume v = make_volume(t, {9, 8, 7});
        v.metadata["who"] = "test";
        write_vdb(v, dir + "/whole.vdb");
        auto planes = planes_of(v);
        write_vdb(*planes, dir + "/planes.vdb");
        const Volume a = read_vdb(dir + "/whole.vdb"), b = read_vdb(dir + "/planes.vdb");
        EXPECT_EQ(a.type, b.type);
        EXPECT_TRUE(a.data == b.data);
        EXPECT_EQ(a.metadata, b.metadata);  // the grid type included
        EXPECT_EQ(a.spacing, b.spacing);
    }
    // The grid type a volume was read from, kept when every value fits (a pass
    // over the planes decides): u32 values within int32 from an int32 grid.
    Volume u = make_volume(ValueType::U32, {6, 5, 4});
    for (int64_t i = 0; i < u.count(); ++i) u.as<uint32_t>()[i] = uint32_t(i * 1000);
    u.metadata["vdb:grid_type"] = "int32";
    auto planes = planes_of(u);
    write_vdb(*planes, dir + "/u.vdb");
    EXPECT_EQ(read_vdb(dir + "/u.vdb").metadata.at("vdb:grid_type"), "int32");
    // Planes that fail mid-way leave nothing.
    FailingPlanes failing(make_volume(ValueType::F32, {5, 5, 5}), 1);
    std::filesystem::remove(dir + "/f.vdb");
    EXPECT_THROW(write_vdb(failing, dir + "/f.vdb"), Error);
    EXPECT_FALSE(std::filesystem::exists(dir + "/f.vdb"));
}
