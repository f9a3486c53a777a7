// `convert --max-error` through the command line (format 3.1 lossy archival):
// percent parsing, info (text and --json) showing the mode and bound, decode
// saying what it honours, verify --deep --original, and the refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_runner.hpp"

using namespace tetlod_cli_test;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A small u8 volume (values 0..255 in the Marschner-Lobb signal) and its lossy container.
std::string sample_raw() {
    const std::string raw = tmp("lossy_ml.raw");
    EXPECT_EQ(run("sample marschner-lobb '" + raw + "' --size 17").code, 0);
    return raw;
}

std::string converted(const std::string& raw, const std::string& name, const std::string& extra) {
    const std::string out = tmp(name + ".tlod");
    const CliRun c = run("convert '" + raw + "' '" + out + "' --dims 17,17,17 --dtype u8 " + extra);
    EXPECT_EQ(c.code, 0) << c.err;
    return out;
}

std::string bytes(const std::string& path) { return slurp(path); }

}  // namespace

TEST(LossyCli, PercentOfTheRangeShownByInfo) {
    const std::string raw = sample_raw();
    // The full table (--table full): a 3.1 file; the default compact table: 3.2.
    const std::string path = converted(raw, "lossy_pct", "--max-error 2% --table full");
    const CliRun j = run("info --json '" + path + "'");
    ASSERT_EQ(j.code, 0) << j.err;
    const auto info = nlohmann::json::parse(j.out);
    EXPECT_EQ(info["field_mode"], "lossy");
    // (3.3 when a field chunk is in the lattice mode, spec §6.4.)
    auto has_lattice = [](const nlohmann::json& j) {
        for (const auto& s : j["sections"])
            if (s.value("mode", "") == "lattice") return true;
        return false;
    };
    EXPECT_EQ(info["format_version"], has_lattice(info) ? "3.3" : "3.1");
    EXPECT_EQ(info["table_layout"], "full");
    const auto compact = nlohmann::json::parse(run("info --json '" + converted(raw, "lossy_pct_c", "--max-error 2%") + "'").out);
    // (3.6 when a field chunk is in the range-2d mode, 3.8 when an error chunk is range-exp.)
    auto has_mode = [](const nlohmann::json& j, const char* mode) {
        for (const auto& s : j["sections"])
            if (s.value("mode", "") == mode) return true;
        return false;
    };
    EXPECT_EQ(compact["format_version"], has_mode(compact, "range-exp")  ? "3.8"
                                         : has_mode(compact, "range-2d") ? "3.6"
                                         : has_lattice(compact)          ? "3.3"
                                                                         : "3.2");
    EXPECT_EQ(compact["table_layout"], "compact");
    EXPECT_LT(compact["table_bytes"].get<uint64_t>(), info["table_bytes"].get<uint64_t>());
    EXPECT_EQ(info["table_bytes"].get<uint64_t>(), 48 * info["sections"].size());
    // 2% of the input's range, multiplied first as --error does: pct * (max - min) / 100.
    const std::string v = bytes(raw);
    int lo = 255, hi = 0;
    for (char c : v) lo = std::min(lo, int((unsigned char)c)), hi = std::max(hi, int((unsigned char)c));
    // A u8 volume honours, and states, the integer part.
    EXPECT_EQ(info["max_error"].get<double>(), std::floor(2.0 * double(hi - lo) / 100.0));
    EXPECT_GE(info["max_error"].get<double>(), 1.0);
    EXPECT_EQ(info["format_keys"]["field.max_error"].get<std::string>().empty(), false);

    const CliRun t = run("info '" + path + "'");
    ASSERT_EQ(t.code, 0) << t.err;
    EXPECT_TRUE(contains(t.out, "lossy: every sample within")) << t.out;

    const CliRun plain = run("info --json '" + converted(raw, "lossless", "--table full") + "'");
    const auto pj = nlohmann::json::parse(plain.out);
    EXPECT_EQ(pj["field_mode"], "lossless");
    EXPECT_EQ(pj["max_error"].get<double>(), 0.0);
    EXPECT_EQ(pj["format_version"], "3.0");
}

TEST(LossyCli, AbsoluteBoundDecodeAndVerify) {
    const std::string raw = sample_raw();
    const std::string path = converted(raw, "lossy_abs", "--max-error 3");
    const CliRun j = run("info --json '" + path + "'");
    EXPECT_EQ(nlohmann::json::parse(j.out)["max_error"].get<double>(), 3.0);

    const std::string back = tmp("lossy_back.raw");
    const CliRun d = run("decode '" + path + "' '" + back + "'");
    ASSERT_EQ(d.code, 0) << d.err;
    EXPECT_TRUE(contains(d.err, "lossy container: every sample within 3 of the original")) << d.err;
    const std::string a = bytes(raw), b = bytes(back);
    ASSERT_EQ(a.size(), b.size());
    int worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        worst = std::max(worst, std::abs(int((unsigned char)a[i]) - int((unsigned char)b[i])));
    EXPECT_LE(worst, 3);
    EXPECT_GT(worst, 0);  // it is lossy
    // -q: no note (errors only, as zstd's -q).
    EXPECT_FALSE(contains(run("-q decode '" + path + "' '" + back + "'").err, "lossy container"));

    const CliRun v = run("verify --deep '" + path + "' --original '" + raw + "' --dims 17,17,17 --dtype u8");
    ASSERT_EQ(v.code, 0) << v.err;
    EXPECT_TRUE(contains(v.out, "lossy: every sample within 3")) << v.out;
    EXPECT_TRUE(contains(v.out, "original: all 4913 samples within 3")) << v.out;
    // Against another volume the statement fails.
    const std::string other = tmp("lossy_other.raw");
    ASSERT_EQ(run("sample sparse '" + other + "' --size 17").code, 0);
    const CliRun w = run("verify '" + path + "' --original '" + other + "' --dims 17,17,17 --dtype u8");
    EXPECT_EQ(w.code, 4) << w.out << w.err;
    EXPECT_TRUE(contains(w.err, "farther than 3")) << w.err;

    // extract --error e honours e (here: reports a largest error no larger).
    const CliRun x = run("extract '" + path + "' '" + tmp("lossy.vtu") + "' --error 10 -f");
    EXPECT_EQ(x.code, 0) << x.err;
    EXPECT_TRUE(contains(x.out, "against the original (lossy field)")) << x.out;
    EXPECT_FALSE(contains(x.err, "warning")) << x.err;
    // Below E no mesh honours the threshold: the finest one is written, its
    // largest error stated as E (not 0), with a warning (not under -q).
    for (const std::string& ask : {std::string("--error 1"), std::string("--error 0"),
                                   std::string("--error 10 --box 0,0,0,4,4,4 --error-out 2")}) {
        const CliRun below = run("extract '" + path + "' '" + tmp("lossy.vtu") + "' -f " + ask);
        EXPECT_EQ(below.code, 0) << ask << below.err;
        EXPECT_TRUE(contains(below.err, "is lossy (every sample within 3 of the original)")) << ask << below.err;
        if (ask.find("--box") == std::string::npos)
            EXPECT_TRUE(contains(below.out, "largest error 3 ")) << ask << below.out;
        EXPECT_FALSE(contains(run("-q extract '" + path + "' '" + tmp("lossy.vtu") + "' -f " + ask).err, "warning"));
    }
    const CliRun full = run("extract '" + path + "' '" + tmp("lossy.vtu") + "' -f --full");
    EXPECT_EQ(full.code, 0) << full.err;
    EXPECT_FALSE(contains(full.err, "warning")) << full.err;  // --full asks for no bound
    EXPECT_TRUE(contains(full.out, "largest error 3 ")) << full.out;
}

TEST(LossyCli, ZeroIsLosslessAndBadBoundsRefused) {
    const std::string raw = sample_raw();
    const std::string a = converted(raw, "zero_a", "--max-error 0 --table full");
    const std::string b = converted(raw, "zero_b", "");
    // The creation time differs between runs: compare the decoded fields and the version.
    const std::string da = tmp("zero_a.raw"), db = tmp("zero_b.raw");
    ASSERT_EQ(run("decode '" + a + "' '" + da + "'").code, 0);
    EXPECT_EQ(bytes(da), bytes(raw));
    EXPECT_EQ(nlohmann::json::parse(run("info --json '" + a + "'").out)["format_version"], "3.0");
    (void)b;
    (void)db;
    for (const char* bad : {"-1", "inf", "nan", "abc", "1%%"}) {
        const CliRun r = run("convert '" + raw + "' '" + tmp("bad.tlod") + "' --dims 17,17,17 --dtype u8 --max-error " + bad);
        EXPECT_EQ(r.code, 2) << bad << ": " << r.err;
    }
    const CliRun mt = run("convert '" + raw + "' '" + tmp("bad.tlod") + "' --dims 17,17,17 --dtype u8 --max-error 1 --model mt");
    EXPECT_EQ(mt.code, 2) << mt.err;
    EXPECT_TRUE(contains(mt.err, "an MT alone stores its field losslessly")) << mt.err;
}

// --model ht,mt --max-error: both models over the stored field (format 3.5), the
// MT's bounds against the original too.
TEST(LossyCli, BothModelsOverTheLossyField) {
    const std::string raw = sample_raw();
    const std::string path = converted(raw, "lossy_ht_mt", "--max-error 3 --model ht,mt");
    const auto info = nlohmann::json::parse(run("info --json '" + path + "'").out);
    bool range2d = false, range_exp = false;  // 3.6, which includes LOSSY_MT, when a field chunk is
    for (const auto& s : info["sections"]) {  // range-2d; 3.8 when an error chunk is range-exp
        range2d = range2d || s.value("mode", "") == "range-2d";
        range_exp = range_exp || s.value("mode", "") == "range-exp";
    }
    EXPECT_EQ(info["format_version"], range_exp ? "3.8" : range2d ? "3.6" : "3.5");
    EXPECT_EQ(info["max_error"].get<double>(), 3.0);
    ASSERT_EQ(info["models"].size(), 2u) << info.dump();
    EXPECT_EQ(info["models"][1]["type"], "MT");
    const CliRun x = run("extract '" + path + "' '" + tmp("lossy_mt.vtu") + "' --model mt --error 10 -f");
    ASSERT_EQ(x.code, 0) << x.err;
    EXPECT_TRUE(contains(x.out, "against the original (lossy field)")) << x.out;
    EXPECT_FALSE(contains(x.err, "warning")) << x.err;
    const CliRun below = run("extract '" + path + "' '" + tmp("lossy_mt.vtu") + "' --model mt --error 1 -f");
    ASSERT_EQ(below.code, 0) << below.err;
    EXPECT_TRUE(contains(below.out, "largest error 3 ")) << below.out;
    EXPECT_TRUE(contains(below.err, "is lossy (every sample within 3 of the original)")) << below.err;
    const CliRun v = run("verify --deep '" + path + "' --original '" + raw + "' --dims 17,17,17 --dtype u8");
    EXPECT_EQ(v.code, 0) << v.out << v.err;
    // The MT's update errors checked against exact errors on the stored field plus E.
    EXPECT_TRUE(contains(v.out, " MT tet bounds >= exact errors (at most ")) << v.out;
}

TEST(LossyCli, StatsStatesTheFieldBoundOfBothModels) {
    // stats on a lossy container says why thresholds below E repeat the full
    // mesh, for each model it holds; on a lossless one it says nothing of it.
    const std::string raw = sample_raw();
    const std::string path = converted(raw, "lossy_stats", "--max-error 3 --model ht,mt");
    const CliRun t = run("stats '" + path + "'");
    ASSERT_EQ(t.code, 0) << t.err;
    const std::string line = "lossy field  every sample within 3 of the original";
    const std::size_t first = t.out.find(line);
    ASSERT_NE(first, std::string::npos) << t.out;
    EXPECT_NE(t.out.find(line, first + 1), std::string::npos) << "one line per model\n" << t.out;
    const CliRun j = run("stats --json '" + path + "'");
    ASSERT_EQ(j.code, 0) << j.err;
    const auto stats = nlohmann::json::parse(j.out);
    ASSERT_EQ(stats["models"].size(), 2u);
    for (const auto& m : stats["models"]) {
        EXPECT_EQ(m["field_max_error"].get<double>(), 3.0) << m["model"];
        // Every uniform threshold below E gives the full mesh (17^3 u8: 0.1 % .. 1 % of 255).
        int below = 0;
        for (const auto& row : m["uniform"])
            if (row["error"].get<double>() < 3.0) {
                ++below;
                EXPECT_EQ(row["tets"].get<double>(), m["full"]["tets"].get<double>()) << m["model"];
            }
        EXPECT_GE(below, 1) << m["model"];
    }
    const CliRun plain = run("stats '" + converted(raw, "lossless_stats", "") + "'");
    ASSERT_EQ(plain.code, 0) << plain.err;
    EXPECT_FALSE(contains(plain.out, "lossy field")) << plain.out;
    EXPECT_EQ(nlohmann::json::parse(run("stats --json '" + tmp("lossless_stats.tlod") + "'").out)["models"][0]
                  ["field_max_error"].get<double>(),
              0.0);
}
