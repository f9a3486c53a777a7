// verify --deep on the HT's diamond bounds (issue 13): every tet of the bisection
// hierarchy in the data box must have a closed error at most its diamond's decoded
// bound minus E (spec §2, §5.1, §8), and a diamond with a tet crossing the box must
// have the bound +inf. The check (ht_bound_check.hpp) generates the hierarchy from
// the spec and recomputes the errors exactly; here it must
//  - pass on what the writer stores (lossless, lossy, padded, every type, awkward dims),
//  - agree with the builder's own errors where those are exact (integer fields: the
//    errors are dyadic, so the float the builder keeps is the exact error), so that
//    lowering any one of them by one float step fails, at that diamond;
//  - refuse a finite bound on a diamond that crosses the box;
//  - refuse a lossy file whose bounds hold against the stored field and are >= E but
//    lack part of the + E (the check before this one let those pass).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "support/volume_generators.hpp"
#include "tetlod/analysis/ht_bound_check.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/lossy_field.hpp"
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

std::array<int64_t, 3> box_of(const HtDomain& d) { return {d.box_max[0], d.box_max[1], d.box_max[2]}; }

HtBoundCheck check_model(const HtModel& m, std::span<const float> bounds, double E = 0) {
    return check_ht_bounds(m.field(), m.domain().k, box_of(m.domain()), bounds, E);
}

TEST(VerifyHt, DeepPassesOnWrittenContainers) {
    for (const Dims dims : {Dims{13, 9, 7}, Dims{17, 17, 17}, Dims{33, 20, 6}})
        for (const ValueType type : {ValueType::U8, ValueType::I16, ValueType::U32, ValueType::F32, ValueType::F64})
            for (const bool pad : {false, true})
                for (const bool lossy : {false, true}) {
                    if (lossy && (type == ValueType::U32 || type == ValueType::F64)) continue;
                    SCOPED_TRACE(std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" + std::to_string(dims.z) +
                                 " " + value_type_name(type) + (pad ? " padded" : "") + (lossy ? " lossy" : ""));
                    const Volume v = test::make_volume(dims, type, test::Field::Smooth);
                    const std::string path = tmp("ht_deep.tlod");
                    ContainerWriteOptions o;
                    o.pad = pad;
                    if (lossy) o.max_error = 0.03 * range_of(v);
                    write_container(Volume(v), path, o);
                    const VerifyReport rep = verify_container(path, true);
                    ASSERT_TRUE(rep.ok()) << rep.failure->message;
                    EXPECT_TRUE(rep.ht_deep_ok);
                    // At least the 6 * cells unit-level parents' tets: more tets than grid points.
                    EXPECT_GT(rep.ht_bounds_checked, uint64_t(dims.count()));
                    EXPECT_GE(rep.ht_worst_bound_ratio, 1.0);
                    EXPECT_TRUE(std::isfinite(rep.ht_worst_bound_ratio));
                    std::filesystem::remove(path);
                }
}

// The builder's errors of an integer field are exact (dyadic rationals, held exactly
// in a float): the independent check accepts them, and each is tight, so lowering one
// by a float step makes the check fail there, naming that diamond.
TEST(VerifyHt, AgreesWithTheBuilderToTheLastBit) {
    for (const auto& [dims, type, pad] : {std::tuple{Dims{13, 9, 7}, ValueType::U8, false},
                                          std::tuple{Dims{12, 17, 9}, ValueType::I16, false},
                                          std::tuple{Dims{9, 9, 9}, ValueType::U8, true}}) {
        SCOPED_TRACE(std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" + std::to_string(dims.z));
        HtBuildOptions bo;
        bo.pad = pad;
        const HtModel m = HtModel::build(test::make_volume(dims, type, test::Field::Noisy), bo);
        const std::span<const float> exact = m.diamond_errors();
        const HtBoundCheck c = check_model(m, exact);
        ASSERT_TRUE(c.ok()) << "first at level " << c.first->level << ": stored " << c.first->stored << ", exact "
                            << c.first->exact;
        EXPECT_GT(c.tets_checked, uint64_t(m.field().dims.count()));
        EXPECT_GT(c.points_visited, 4 * c.tets_checked);
        // Bounds equal to the exact errors: the double filter cannot tell, the exact path decides.
        EXPECT_GT(c.exact_comparisons, 0u);
        EXPECT_GE(c.worst_ratio, 1.0);  // per tet: a diamond's smaller tets are below its bound
        if (!pad) {
            EXPECT_GT(c.crossing_tets, 0u);
        }
        const Dims d = m.field().dims;
        int lowered = 0;
        for (size_t i = 0; i < exact.size() && lowered < 12; i += 37) {
            if (!(exact[i] > 0) || !std::isfinite(exact[i])) continue;
            std::vector<float> b(exact.begin(), exact.end());
            b[i] = std::nextafter(b[i], 0.0f);
            const HtBoundCheck bad = check_model(m, b);
            ASSERT_FALSE(bad.ok()) << "grid point " << i;
            EXPECT_FALSE(bad.first->crossing);
            EXPECT_EQ(d.index(bad.first->centre[0], bad.first->centre[1], bad.first->centre[2]), int64_t(i));
            EXPECT_EQ(bad.first->stored, double(b[i]));
            EXPECT_EQ(bad.first->exact, double(exact[i]));
            ++lowered;
        }
        EXPECT_GE(lowered, 6);
    }
}

TEST(VerifyHt, CrossingDiamondsMustBeUnbounded) {
    const HtModel m = HtModel::build(test::make_volume({13, 9, 7}, ValueType::U8, test::Field::Smooth));
    std::vector<float> b(m.diamond_errors().begin(), m.diamond_errors().end());
    size_t crossing = b.size();
    for (size_t i = 0; i < b.size() && crossing == b.size(); ++i)
        if (std::isinf(b[i])) crossing = i;
    ASSERT_LT(crossing, b.size()) << "13x9x7 sits in a 16^3 cube: some diamonds cross the data box";
    b[crossing] = 1e30f;
    const HtBoundCheck bad = check_model(m, b);
    ASSERT_FALSE(bad.ok());
    EXPECT_TRUE(bad.first->crossing);
    EXPECT_EQ(m.field().dims.index(bad.first->centre[0], bad.first->centre[1], bad.first->centre[2]),
              int64_t(crossing));
    // Sizes that disagree are refused, as is a bad E.
    EXPECT_THROW(check_model(m, std::span<const float>(b.data(), b.size() - 1)), Error);
    EXPECT_THROW(check_model(m, b, -1), Error);
    EXPECT_THROW(check_ht_bounds(m.field(), m.domain().k - 1, box_of(m.domain()), b, 0), Error);
}

// A lossy file whose stated bounds are the stored field's errors plus only half of E:
// each is >= the error against the stored field and >= E (what the deep check used to
// require), but not >= error + E, so against the original they may fail.
TEST(VerifyHt, LossyBoundsMissingPartOfEFailDeepOnly) {
    Volume fprime = test::make_volume({17, 13, 11}, ValueType::U8, test::Field::Smooth);
    const double E = 4;
    quantize_volume(fprime, E);
    const HtModel built = HtModel::build(Volume(fprime));
    std::vector<float> errs(built.diamond_errors().begin(), built.diamond_errors().end());
    // The diamond to understate: finite error of at least E / 2 (so error + E / 2 >= E).
    size_t target = errs.size();
    for (size_t i = 0; i < errs.size() && target == errs.size(); ++i)
        if (std::isfinite(errs[i]) && errs[i] >= E / 2 && errs[i] < 64) target = i;
    ASSERT_LT(target, errs.size());
    const float original_error = errs[target];
    errs[target] = float(original_error - E / 2);  // the reader adds E: bound = error + E / 2 (rounded up)
    ZeroedVector<float> z(errs.size());
    std::copy(errs.begin(), errs.end(), z.data());
    const HtModel lowered = HtModel::from_parts(Volume(fprime), built.domain(), std::move(z));
    const std::string path = tmp("ht_half_e.tlod");
    {
        tlod::ContainerWriter w;
        HtEncodeOptions eo;
        eo.max_error = E;
        ASSERT_TRUE(encode_ht(lowered, tlod::metadata_for_volume(fprime), w, eo));
        w.write(path);
    }
    const VerifyReport plain = verify_container(path, false);
    ASSERT_TRUE(plain.ok()) << plain.failure->message;
    EXPECT_EQ(plain.max_error, E);
    const VerifyReport deep = verify_container(path, true);
    ASSERT_FALSE(deep.ok());
    EXPECT_EQ(deep.failure->code, ErrorCode::CorruptData);
    const Dims d = fprime.dims;
    const std::string centre = "(" + std::to_string(target % d.x) + "," + std::to_string(target / d.x % d.y) + "," +
                               std::to_string(target / (d.x * d.y)) + ")";
    EXPECT_NE(deep.failure->message.find("the diamond at " + centre), std::string::npos) << deep.failure->message;
    EXPECT_NE(deep.failure->message.find("(the file is lossy)"), std::string::npos) << deep.failure->message;
    EXPECT_NE(deep.failure->message.find(path), std::string::npos);
    std::filesystem::remove(path);
}

}  // namespace
