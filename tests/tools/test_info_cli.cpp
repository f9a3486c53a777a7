// `tetlod info` as a script and a person read it (issue 13 Must 4): the coder of
// every kind of section and its bytes, in the text and in --json, with the
// keys scripts already use left as they were.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_runner.hpp"

namespace fs = std::filesystem;
using namespace tetlod_cli_test;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A small container made through the CLI, as a user would.
std::string converted(const std::string& name, const std::string& extra) {
    const std::string raw = tmp(name + ".raw"), out = tmp(name + ".tlod");
    EXPECT_EQ(run("sample sparse '" + raw + "' --size 17").code, 0);
    const CliRun c = run("convert '" + raw + "' '" + out + "' --dims 17,17,17 --dtype u8 " + extra);
    EXPECT_EQ(c.code, 0) << c.err;
    return out;
}

}  // namespace

TEST(InfoCli, TextListsCodersAndBytes) {
    const std::string path = converted("info_ht", "");
    const CliRun r = run("info '" + path + "'");
    ASSERT_EQ(r.code, 0) << r.err;
    for (const char* s : {"coder", "METADATA", "zstd", "HT_HEADER", "stored", "HT_FIELD", "HT_ERRORS",
                          "ht-range-v2", "header+table"})
        EXPECT_TRUE(contains(r.out, s)) << s << "\n" << r.out;
    EXPECT_FALSE(contains(r.out, "MT_STRUCTURE")) << r.out;

    const CliRun s = run("info --sections '" + path + "'");
    ASSERT_EQ(s.code, 0) << s.err;
    EXPECT_TRUE(contains(s.out, "arg1  coder")) << s.out;
}

TEST(InfoCli, JsonCodersAddUpToTheFile) {
    const std::string path = converted("info_both", "--model ht,mt");
    const CliRun r = run("info --json '" + path + "'");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    // Keys scripts rely on are still there.
    for (const char* k : {"file_size", "format_version", "dims", "models", "sections", "bytes_read"})
        EXPECT_TRUE(j.contains(k)) << k;
    ASSERT_TRUE(j.contains("coders"));
    uint64_t stored = 0, count = 0;
    std::map<std::string, std::string> coder;
    for (const auto& c : j["coders"]) {
        stored += c["stored_bytes"].get<uint64_t>();
        count += c["count"].get<uint64_t>();
        coder[c["section"].get<std::string>()] = c["coder"].get<std::string>();
        EXPECT_GE(c["share"].get<double>(), 0.0);
    }
    EXPECT_EQ(stored + j["framing_bytes"].get<uint64_t>(), j["file_size"].get<uint64_t>());
    EXPECT_EQ(count, j["sections"].size());
    EXPECT_EQ(coder["HT_FIELD"], "ht-range-v2");
    EXPECT_EQ(coder["HT_ERRORS"], "ht-range-v2");
    EXPECT_EQ(coder["MT_STRUCTURE"], "mt-zstd-payload");
    EXPECT_EQ(coder["MT_HEADER"], "stored");
    EXPECT_EQ(coder["METADATA"], "zstd");
    // Each section names its coder too, the same as its row.
    for (const auto& s : j["sections"]) EXPECT_EQ(s["coder"], coder[s["type"].get<std::string>()]) << s;
}
