// `tetlod info` as a script and a person read it (issue 13 Must 4): the coder of
// every kind of section and its bytes, in the text and in --json, with the
// keys scripts already use left as they were.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>
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
                          "ht-range-v2", "ht-zero-residual", "ht-samples+zstd", "header+table"})
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
    // Section kind -> its rows' coders (format 3.0: one row per chunk mode).
    std::map<std::string, std::set<std::string>> coders;
    std::map<std::string, std::set<std::string>> modes;
    for (const auto& c : j["coders"]) {
        stored += c["stored_bytes"].get<uint64_t>();
        count += c["count"].get<uint64_t>();
        coders[c["section"].get<std::string>()].insert(c["coder"].get<std::string>());
        if (c.contains("mode")) modes[c["section"].get<std::string>()].insert(c["mode"].get<std::string>());
        EXPECT_GE(c["share"].get<double>(), 0.0);
    }
    EXPECT_EQ(stored + j["framing_bytes"].get<uint64_t>(), j["file_size"].get<uint64_t>());
    EXPECT_EQ(count, j["sections"].size());
    EXPECT_TRUE(coders["HT_FIELD"].count("ht-range-v2"));
    EXPECT_TRUE(coders["HT_ERRORS"].count("ht-range-v2"));
    // A sparse volume: zero chunks cost nothing (zero-residual), the blob range codes.
    EXPECT_TRUE(modes["HT_FIELD"].count("range") && modes["HT_FIELD"].count("zero-residual"));
    EXPECT_TRUE(modes["HT_ERRORS"].count("range"));
    EXPECT_EQ(coders["MT_STRUCTURE"], std::set<std::string>{"mt-zstd-payload"});
    EXPECT_EQ(coders["MT_HEADER"], std::set<std::string>{"stored"});
    EXPECT_EQ(coders["METADATA"], std::set<std::string>{"zstd"});
    // Each section names its coder (and, for HT chunks, its mode) too, one of its kind's rows.
    for (const auto& s : j["sections"]) {
        const std::string type = s["type"].get<std::string>();
        EXPECT_TRUE(coders[type].count(s["coder"].get<std::string>())) << s;
        EXPECT_EQ(s.contains("mode"), type == "HT_FIELD" || type == "HT_ERRORS") << s;
    }
}

// Format 3.6: where the two-dimensional contexts code a field chunk smaller the
// writer takes them (range-2d, spec §6.4, §7.6) and the file says 3.6; info names
// the coder; the bytes decode to the volume. `--table full` is for older readers:
// a 3.0 file, no range-2d chunk.
TEST(InfoCli, Range2dChunksMakeA36FileAndTableFullKeepsThemOut) {
    const std::string raw = tmp("range2d.raw");
    ASSERT_EQ(run("sample multiscale '" + raw + "' --size 33").code, 0);
    auto convert = [&](const std::string& name, const std::string& extra) {
        const std::string out = tmp(name + ".tlod");
        const CliRun c = run("convert '" + raw + "' '" + out + "' --dims 33,33,33 --dtype u8 -f " + extra);
        EXPECT_EQ(c.code, 0) << c.err;
        return out;
    };
    auto range2d_sections = [](const nlohmann::json& j) {
        int n = 0;
        for (const auto& s : j["sections"]) n += s.value("mode", "") == "range-2d";
        return n;
    };
    for (const std::string& extra : {std::string(), std::string("--table full")}) {
        const std::string path = convert(extra.empty() ? "range2d_default" : "range2d_full", extra);
        const CliRun j = run("info --json '" + path + "'");
        ASSERT_EQ(j.code, 0) << j.err;
        const auto info = nlohmann::json::parse(j.out);
        if (extra.empty()) {
            EXPECT_GT(range2d_sections(info), 0) << j.out;
            EXPECT_EQ(info["format_version"], "3.8");  // 3.6 for range-2d, 3.8 for the range-exp error chunks
            EXPECT_TRUE(contains(run("info '" + path + "'").out, "ht-range-exp"));
            EXPECT_TRUE(contains(run("info '" + path + "'").out, "ht-range-2d"));
        } else {
            EXPECT_EQ(range2d_sections(info), 0) << j.out;
            EXPECT_EQ(info["format_version"], "3.0");
            for (const auto& s : info["sections"]) EXPECT_NE(s.value("mode", ""), "range-exp") << j.out;
        }
        const std::string back = tmp("range2d_back.raw");
        ASSERT_EQ(run("decode '" + path + "' '" + back + "' -f -q").code, 0);
        EXPECT_EQ(slurp(back), slurp(raw)) << extra;
    }
}

// Format 3.7: `convert --fast-decode` codes the field for decoding speed (chunk
// mode 6, static, spec §6.4, §7.6): a file of static field chunks (3.8: its
// error chunks are range-exp, as by default) whose info names the coder and
// whose bytes decode to the volume; with `--table full` (for older readers) it
// is refused, naming the conflict, before anything is written.
TEST(InfoCli, FastDecodeMakesA37FileOfStaticChunks) {
    const std::string raw = tmp("fast.raw");
    ASSERT_EQ(run("sample multiscale '" + raw + "' --size 33 --dtype u16").code, 0);
    const std::string path = tmp("fast.tlod");
    const CliRun c = run("convert '" + raw + "' '" + path + "' --dims 33,33,33 --dtype u16 -f --fast-decode");
    ASSERT_EQ(c.code, 0) << c.err;
    const CliRun j = run("info --json '" + path + "'");
    ASSERT_EQ(j.code, 0) << j.err;
    const auto info = nlohmann::json::parse(j.out);
    int statics = 0, ranges = 0, range_exp = 0;
    for (const auto& s : info["sections"]) {
        if (s.value("type", "") == "HT_FIELD") {
            statics += s.value("mode", "") == "static";
            ranges += s.value("mode", "") == "range" || s.value("mode", "") == "range-2d";
        }
        range_exp += s.value("mode", "") == "range-exp";
    }
    EXPECT_EQ(info["format_version"].get<std::string>(), range_exp > 0 ? "3.8" : "3.7");
    EXPECT_GT(statics, 0) << j.out;
    EXPECT_EQ(ranges, 0) << j.out;
    EXPECT_TRUE(contains(run("info '" + path + "'").out, "ht-static-rans"));
    const std::string back = tmp("fast_back.raw");
    ASSERT_EQ(run("decode '" + path + "' '" + back + "' -f -q").code, 0);
    EXPECT_EQ(slurp(back), slurp(raw));
    const CliRun v = run("verify '" + path + "'");
    EXPECT_EQ(v.code, 0) << v.err;

    const std::string refused = tmp("fast_full.tlod");
    const CliRun f =
        run("convert '" + raw + "' '" + refused + "' --dims 33,33,33 --dtype u16 -f --fast-decode --table full");
    EXPECT_EQ(f.code, 2) << f.err;
    EXPECT_TRUE(contains(f.err, "compact table")) << f.err;
    EXPECT_FALSE(std::filesystem::exists(refused));
}
