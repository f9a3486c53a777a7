// verify --deep on the MT's stored update errors (issue 13): every tet of a full
// refinement must have a closed error at most its creator's stored error
// (spec/mt-model.md §M4), plus E in a LOSSY_MT file (spec §5.1). Containers
// written by the library pass, lossless and lossy, integer and float; containers
// whose MT understates an error (written through the encoder, every structural
// rule kept, so plain verify passes) fail the deep check with CorruptData naming
// the update; and so does a lossy file whose MT errors hold against the stored
// field and are >= E, but lack the + E.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "support/mesh_checker.hpp"
#include "support/mt_beside_ht.hpp"
#include "support/volume_generators.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tetlod/tetlod.hpp"

using namespace tetlod;

namespace {

std::string tmp(const std::string& name) {
    return (std::filesystem::path(TETLOD_TEST_TMP) / (std::to_string(::getpid()) + "_" + name)).string();
}

double range_of(const Volume& v) {
    const auto r = v.range();
    return r[1] - r[0];
}

std::string at(uint32_t g, const Dims& d) {
    const int64_t i = g;
    return "(" + std::to_string(i % d.x) + "," + std::to_string(i / d.x % d.y) + "," + std::to_string(i / (d.x * d.y)) +
           ")";
}

/// `mt` with every update's error replaced by edit(k, error), reassembled through
/// from_parts (which checks labels and monotonicity again).
MtModel with_errors(const MtModel& mt, const std::function<float(size_t, float)>& edit) {
    std::vector<MtUpdate> ups;
    ups.reserve(mt.updates().size());
    for (size_t k = 0; k < mt.updates().size(); ++k) {
        const MtSplit& u = mt.updates()[k];
        ups.push_back(MtUpdate{u.w, mt.survivor(k), u.label, edit(k, u.error), u.star});
    }
    return MtModel::from_parts(mt.field(), mt.base_tets(), std::move(ups), mt.mask_bits());
}

/// The HT-only container `ht_only` with `mt` added beside its HT (field_error: the
/// E the encoder adds to every update error; 0 for a lossless file).
std::string with_mt(const std::string& ht_only, const MtModel& mt, double field_error, const std::string& name) {
    const std::string out = tmp(name);
    test::write_mt_beside_ht(ht_only, mt, field_error, out);
    return out;
}

void expect_deep_ok(const std::string& path) {
    const VerifyReport rep = verify_container(path, true);
    ASSERT_TRUE(rep.ok()) << rep.failure->message;
    EXPECT_TRUE(rep.mt_deep_ok && rep.ht_deep_ok);
    // Every tet of the full mesh is visited, and more on the way.
    EXPECT_GT(rep.mt_bounds_checked, rep.mt_reference_tets);
    EXPECT_EQ(rep.mt_bounds_unchecked, 0u);
    EXPECT_GE(rep.mt_worst_bound_ratio, 1.0);
    EXPECT_TRUE(std::isfinite(rep.mt_worst_bound_ratio));
}

// (a) What the writer stores passes, lossless and lossy, on awkward dims.
TEST(VerifyMt, DeepPassesOnLosslessContainers) {
    for (const Dims dims : {Dims{13, 9, 7}, Dims{33, 33, 33}})
        for (const ValueType type : {ValueType::U8, ValueType::I16, ValueType::U32, ValueType::F32, ValueType::F64}) {
            if (dims.x == 33 && type != ValueType::U8) continue;  // a larger one: seconds each
            for (const test::Field field : {test::Field::Smooth, test::Field::Plateau}) {
                if (dims.x == 33 && field != test::Field::Smooth) continue;
                SCOPED_TRACE(std::to_string(dims.x) + " " + value_type_name(type) + " " + test::field_name(field));
                const std::string path = tmp("lossless.tlod");
                ContainerWriteOptions o;
                o.mt = true;
                write_container(test::make_volume(dims, type, field), path, o);
                expect_deep_ok(path);
            }
        }
}

TEST(VerifyMt, DeepPassesOnLossyContainers) {
    for (const Dims dims : {Dims{13, 9, 7}, Dims{33, 33, 33}})
        for (const ValueType type : {ValueType::U8, ValueType::I16, ValueType::F32}) {
            if (dims.x == 33 && type != ValueType::U8) continue;
            SCOPED_TRACE(std::to_string(dims.x) + " " + value_type_name(type));
            const Volume v = test::make_volume(dims, type, test::Field::Smooth);
            const std::string path = tmp("lossy.tlod");
            ContainerWriteOptions o;
            o.mt = true;
            o.max_error = 0.02 * range_of(v);
            write_container(Volume(v), path, o);
            const ContainerInfo info = inspect_container(path).take();
            ASSERT_GT(info.max_error, 0);  // the case under test: format 3.5, LOSSY_MT
            // (3.6, which includes it, when a field chunk is range-2d; 3.8 when an
            // error chunk is range-exp)
            const bool range2d = std::any_of(info.sections.begin(), info.sections.end(), [](const tlod::SectionInfo& s) {
                return s.type == tlod::kSectionHtField && tlod::section_mode(s.flags) == 5;
            });
            const bool range_exp = std::any_of(info.sections.begin(), info.sections.end(), [](const tlod::SectionInfo& s) {
                return s.type == tlod::kSectionHtErrors && tlod::section_mode(s.flags) == 7;
            });
            EXPECT_EQ(info.header.version_minor, range_exp ? 8 : range2d ? 6 : 5);
            EXPECT_TRUE(info.header.required_features & tlod::kFeatureLossyMt);
            expect_deep_ok(path);
            EXPECT_EQ(verify_container(path, true).max_error, info.max_error);
        }
}

// The check reads the model directly too: a built model passes, with every point
// of every visited tet evaluated.
TEST(VerifyMt, BuiltModelsPass) {
    const MtModel mt = MtModel::build(test::make_volume({13, 9, 7}, ValueType::I16, test::Field::Noisy));
    const MtBoundCheck c = check_mt_bounds(mt);
    EXPECT_TRUE(c.ok());
    EXPECT_EQ(c.full_mesh_tets, 5u * 12 * 8 * 6);
    EXPECT_GT(c.tets_checked, c.full_mesh_tets);  // the tets of the meshes on the way too
    EXPECT_GE(c.points_visited, 4 * c.tets_checked);
    EXPECT_THROW(check_mt_bounds(mt, -1), Error);
    EXPECT_THROW(check_mt_bounds(mt, std::nan("")), Error);
}

/// The update to understate: the one whose error most exceeds what monotonicity
/// needs (its previous update on the same survivor and the last update of the point
/// it inserts), so that error came from its own creation star.
struct Lowered {
    size_t k = 0;
    float floor = 0;  // the lowest error the structural rules allow
};
Lowered most_lowerable(const MtModel& mt) {
    Lowered best;
    double gap = -1;
    for (size_t k = 0; k < mt.updates().size(); ++k) {
        const MtSplit& u = mt.updates()[k];
        const uint32_t s = mt.survivor(k);
        float floor = 0;
        if (k > mt.first_update_at(s)) floor = std::max(floor, mt.updates()[k - 1].error);
        const auto below = mt.updates_at(u.w);
        if (!below.empty()) floor = std::max(floor, below.back().error);
        if (u.error > 2 * floor && double(u.error) - floor > gap) gap = double(u.error) - floor, best = {k, floor};
    }
    return best;
}

// (b) A lossless container whose MT understates one update's error: plain verify
// passes (every structural rule holds), --deep fails naming that update.
TEST(VerifyMt, UnderstatedErrorFailsDeepOnly) {
    for (const ValueType type : {ValueType::U8, ValueType::F32}) {
        SCOPED_TRACE(value_type_name(type));
        const Volume v = test::make_volume({13, 9, 7}, type, test::Field::Smooth);
        const std::string ht_only = tmp("ht_only.tlod");
        write_container(Volume(v), ht_only, ContainerWriteOptions{});
        const MtModel mt = MtModel::build(decode_container(ht_only).take());
        // The same MT through the same path passes: only the lowered error fails below.
        expect_deep_ok(with_mt(ht_only, mt, 0, "honest.tlod"));

        const Lowered low = most_lowerable(mt);
        ASSERT_GT(mt.updates()[low.k].error, 0.0f);
        const MtModel bad = with_errors(mt, [&](size_t k, float e) { return k == low.k ? low.floor : e; });
        const std::string path = with_mt(ht_only, bad, 0, "understated.tlod");
        const VerifyReport plain = verify_container(path, false);
        ASSERT_TRUE(plain.ok()) << plain.failure->message;
        EXPECT_TRUE(plain.mt_ok);
        const VerifyReport deep = verify_container(path, true);
        ASSERT_FALSE(deep.ok());
        EXPECT_EQ(deep.failure->code, ErrorCode::CorruptData);
        EXPECT_TRUE(deep.mt_ok);
        EXPECT_FALSE(deep.mt_deep_ok);
        const std::string& msg = deep.failure->message;
        const MtSplit& u = mt.updates()[low.k];
        EXPECT_NE(msg.find(path), std::string::npos) << msg;
        EXPECT_NE(msg.find("the update at " + at(mt.survivor(low.k), v.dims) + " label " + std::to_string(u.label) +
                           " (inserting " + at(u.w, v.dims) + ")"),
                  std::string::npos)
            << msg;
        EXPECT_NE(msg.find("closed error above their creator's stored error"), std::string::npos) << msg;
        EXPECT_NE(msg.find("stored "), std::string::npos) << msg;
        EXPECT_NE(msg.find(", exact "), std::string::npos) << msg;
        // The checker itself, on the decoded model: the violations are that update's.
        const MtBoundCheck c = check_mt_bounds(load_mt_model(path));
        ASSERT_FALSE(c.ok());
        ASSERT_TRUE(c.first);
        EXPECT_EQ(c.first->creator, mt.survivor(low.k));
        EXPECT_EQ(c.first->label, u.label);
        EXPECT_GT(c.first->exact, c.first->stored);
        // Its tet's closed error, by the independent checker of tests/support.
        test::TetPts pts;
        for (int i = 0; i < 4; ++i) {
            const int64_t g = c.first->tet[i];
            pts[i] = {int32_t(g % v.dims.x), int32_t(g / v.dims.x % v.dims.y), int32_t(g / (v.dims.x * v.dims.y))};
        }
        EXPECT_NEAR(test::exact_tet_error(mt.field(), pts), c.first->exact, 1e-9 * range_of(v));
    }
}

// (c) A lossy (LOSSY_MT) container whose MT errors hold against the stored field
// f' and are >= E, so the reader's own check (an error below E is CorruptData)
// passes, but lack the + E: stored = max(err', E) (+ a hair) < err' + E wherever
// err' > 0. Deep verify must refuse it; the honest MT (err' + E) passes.
TEST(VerifyMt, LossyErrorsWithoutTheFieldsLossFailDeep) {
    for (const ValueType type : {ValueType::U8, ValueType::F32}) {
        SCOPED_TRACE(value_type_name(type));
        const Volume v = test::make_volume({13, 9, 7}, type, test::Field::Smooth);
        const std::string ht_only = tmp("lossy_ht_only.tlod");
        ContainerWriteOptions o;
        o.max_error = 0.03 * range_of(v);
        write_container(Volume(v), ht_only, o);
        const double E = inspect_container(ht_only).take().max_error;
        ASSERT_GT(E, 0);
        const MtModel mt = MtModel::build(decode_container(ht_only).take());  // on f'
        expect_deep_ok(with_mt(ht_only, mt, E, "lossy_honest.tlod"));

        const float e32 = float(E) >= E ? float(E) : std::nextafter(float(E), INFINITY);
        const MtModel short_of_e = with_errors(mt, [&](size_t, float e) { return std::max(e, e32); });
        // The encoder insists on a positive E beside a lossy HT: a tiny one.
        const std::string path = with_mt(ht_only, short_of_e, E * 1e-6, "lossy_without_e.tlod");
        const VerifyReport plain = verify_container(path, false);
        ASSERT_TRUE(plain.ok()) << plain.failure->message;  // every error >= E: the reader accepts it
        const VerifyReport deep = verify_container(path, true);
        ASSERT_FALSE(deep.ok());
        EXPECT_EQ(deep.failure->code, ErrorCode::CorruptData);
        EXPECT_NE(deep.failure->message.find("(the file is lossy)"), std::string::npos) << deep.failure->message;
        EXPECT_NE(deep.failure->message.find(path), std::string::npos) << deep.failure->message;
        // Against f' alone (no E) the same errors hold: only the + E is missing.
        EXPECT_TRUE(check_mt_bounds(load_mt_model(path), 0).ok());
        EXPECT_FALSE(check_mt_bounds(load_mt_model(path), E).ok());
    }
}

// The comparison is exact, as spec §5.1 states it (stored >= err' + E in exact
// arithmetic), not as binary64 would round it. A single spike of value h in a field
// of zeros: a tet with the spike strictly inside or on a face (not a corner) has
// zero corner values, so its closed error is exactly h, the largest of any tet.
TEST(VerifyMt, ComparisonIsExact) {
    for (const ValueType type : {ValueType::U8, ValueType::F64}) {
        for (const double h : {1.0, 0.1}) {
            if (type == ValueType::U8 && h != 1.0) continue;
            SCOPED_TRACE(std::string(value_type_name(type)) + " h=" + std::to_string(h));
            Volume v = Volume::allocate({5, 4, 3}, type);
            dispatch_value_type(type, [&](auto tag) {
                using T = decltype(tag);
                v.as<T>()[v.dims.index(2, 1, 1)] = T(h);
            });
            const MtModel mt = MtModel::build(Volume(v));
            auto all = [&](float e) { return with_errors(mt, [e](size_t, float) { return e; }); };
            const float s = float(h) >= h ? float(h) : std::nextafter(float(h), 1.0f);  // smallest float >= h
            EXPECT_TRUE(check_mt_bounds(all(s)).ok());
            // One float below: the spike's tets fail (so they are visited).
            EXPECT_FALSE(check_mt_bounds(all(std::nextafter(float(h), 0.0f))).ok());
            // stored - E == h exactly: holds. With E one double step larger it fails,
            // though binary64 rounds h + E back to at most the stored value.
            const double e = double(s) - h;  // exact (Sterbenz) and >= 0
            EXPECT_TRUE(check_mt_bounds(all(s), e).ok());
            const double e_up = std::nextafter(e, 1.0);
            EXPECT_LE(h + e_up, double(s)) << "binary64 would accept it";
            const MtBoundCheck c = check_mt_bounds(all(s), e_up);
            EXPECT_FALSE(c.ok());
            if (c.first) {
                EXPECT_DOUBLE_EQ(c.first->exact, h);
            }
            // A tiny E on a bound equal to the error: 1 + 2^-70 rounds to 1.
            if (h == 1.0) {
                EXPECT_EQ(1.0 + 0x1p-70, 1.0);
                EXPECT_FALSE(check_mt_bounds(all(1.0f), 0x1p-70).ok());
            }
        }
    }
}

}  // namespace
