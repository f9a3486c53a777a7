// FIFOs where a regular file is needed are refused before they are opened
// (opening a FIFO for reading blocks until a writer comes: a hang), with exit
// code 3 and a message naming the kind of file. `timeout` turns a hang into a
// failure (exit 124) instead of a stuck test.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_runner.hpp"

namespace {

using namespace tetlod_cli_test;

std::string fresh_dir(const std::string& name) {
    const std::string d = tmp(name);
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

TEST(CliSpecialFiles, FifoInputsAreRefusedQuickly) {
    const std::string dir = fresh_dir("fifo_inputs");
    struct Case {
        std::string name, command;
    };
    const std::vector<Case> cases = {
        {"in.tlod", "info '" + dir + "/in.tlod'"},
        {"in.tlod", "verify '" + dir + "/in.tlod'"},
        {"in.nrrd", "convert '" + dir + "/in.nrrd' '" + dir + "/o1.tlod'"},
        {"in_4x4x4_uint8.raw", "convert '" + dir + "/in_4x4x4_uint8.raw' '" + dir + "/o2.tlod'"},
        {"in.mhd", "convert '" + dir + "/in.mhd' '" + dir + "/o3.tlod'"},
        {"in.h5", "convert '" + dir + "/in.h5:/volume' '" + dir + "/o4.tlod'"},
        {"in.vdb", "convert '" + dir + "/in.vdb' '" + dir + "/o5.tlod'"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.command);
        const std::string fifo = dir + "/" + c.name;
        if (!std::filesystem::exists(fifo)) {
            ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
        }
        const CliRun r = sh("timeout 30 '" + std::string(TETLOD_CLI_PATH) + "' " + c.command);
        EXPECT_EQ(r.code, 3) << r.err;
        EXPECT_NE(r.err.find("FIFO"), std::string::npos) << r.err;
    }
}

// A detached NRRD header whose data file is a FIFO: the header is fine, the
// data file is refused before it is opened.
TEST(CliSpecialFiles, FifoDataFileOfADetachedHeaderIsRefused) {
    const std::string dir = fresh_dir("fifo_data");
    ASSERT_EQ(::mkfifo((dir + "/data.raw").c_str(), 0600), 0);
    {
        std::ofstream h(dir + "/head.nhdr");
        h << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: data.raw\n";
    }
    {
        std::ofstream m(dir + "/head.mhd");
        m << "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\nElementDataFile = data.raw\n";
    }
    for (const char* header : {"head.nhdr", "head.mhd"}) {
        SCOPED_TRACE(header);
        const CliRun r = sh("timeout 30 '" + std::string(TETLOD_CLI_PATH) + "' convert '" + dir + "/" + header +
                            "' '" + dir + "/" + header + ".tlod'");
        EXPECT_EQ(r.code, 3) << r.err;
        EXPECT_NE(r.err.find("FIFO"), std::string::npos) << r.err;
    }
}

}  // namespace
