// The OpenVDB converter is a module the format table loads when a .vdb file is
// first read or written (tetlod/converters/vdb_module.hpp): a process that
// never touches one never maps libopenvdb, whose dynamic linking alone cost
// ~38 ms per `tetlod` command. Checked from the process's own mappings, so the
// test does not trust the loader it checks.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "tetlod/converters/volume_formats.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/volume.hpp"

namespace {

using namespace tetlod;

std::string tmp(const std::string& name) { return std::string(TETLOD_TEST_TMP) + "/" + name; }

bool mapped(const std::string& library) {
    std::ifstream maps("/proc/self/maps");
    std::string line;
    while (std::getline(maps, line))
        if (line.find(library) != std::string::npos) return true;
    return false;
}

Volume sample() {
    Volume v = Volume::allocate(Dims{5, 4, 3}, ValueType::F32);
    float* p = v.as<float>();
    for (int64_t i = 0; i < v.count(); ++i) p[i] = float(i) * 0.5f - 3.0f;
    return v;
}

}  // namespace

// First in the file: the module is loaded once per process, so the refusal is
// checked in a fresh process (threadsafe death tests re-run this binary).
TEST(VdbModuleDeathTest, NamedModuleThatCannotLoadIsAClearError) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    const std::string path = tmp("named.vdb");
    EXPECT_EXIT(
        {
            setenv("TETLOD_VDB_MODULE", "/nonexistent/libtetlod_vdb_io.so", 1);
            try {
                write_volume(sample(), path);
            } catch (const Error& e) {
                const std::string what = e.what();
                std::exit(e.code() == ErrorCode::NotBuilt && what.find("/nonexistent/libtetlod_vdb_io.so") != std::string::npos &&
                                  what.find("TETLOD_VDB_MODULE") != std::string::npos
                              ? 3
                              : 4);
            }
            std::exit(5);
        },
        testing::ExitedWithCode(3), "");
}

TEST(VdbModule, LoadedOnFirstUseOnly) {
    ASSERT_FALSE(mapped("libopenvdb")) << "libopenvdb mapped before any .vdb file was touched";
    const Volume v = sample();
    const std::string path = tmp("v.vdb");
    EXPECT_EQ(locate_volume(path).format->name, "vdb");
    EXPECT_FALSE(mapped("libopenvdb")) << "choosing the format loaded the module";
    write_volume(v, path);
    EXPECT_TRUE(mapped("libopenvdb"));
    const Volume back = read_volume(path);
    EXPECT_EQ(back.dims, v.dims);
    EXPECT_EQ(back.type, v.type);
    EXPECT_TRUE(back.data == v.data);
}
