// The MT in the container (spec/tlod-format.md §10): HT+MT and MT-only files
// round trip (extraction from the loaded MT equals extraction from the built MT
// after its own codec round trip, whose upward-rounded errors the container
// keeps), the HT of an HT+MT file still decodes, and every prefix and every
// single-bit flip of a file with MT sections fails cleanly.
#include <gtest/gtest.h>

#include <cstring>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/container.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;
using namespace tetlod::tlod;

namespace {

struct Fixture {
    Volume vol;
    MtModel mt;
    std::vector<std::byte> both, mt_only;
};

Fixture make(Dims d, ValueType t) {
    Fixture f;
    f.vol = tlodtest::make_volume(d, t, 11);
    f.vol.metadata["user.note"] = "mt";
    f.mt = MtModel::build(f.vol);
    const Metadata meta = metadata_for_volume(f.vol);
    {
        ContainerWriter w;
        encode_ht(HtModel::build(f.vol), meta, w);
        encode_mt_container(f.mt, meta, w, true);
        f.both = w.finish();
    }
    {
        ContainerWriter w;
        encode_mt_container(f.mt, meta, w, false);
        f.mt_only = w.finish();
    }
    return f;
}

std::vector<LodQuery> queries(const Volume& v) {
    const auto r = v.range();
    std::vector<LodQuery> qs(4);
    qs[0].full = true;
    qs[1].error_in = 0.0;
    qs[2].error_in = 0.05 * (r[1] - r[0]);
    qs[3].error_in = 0.0, qs[3].error_out = 0.2 * (r[1] - r[0]);
    qs[3].box = std::array<int64_t, 6>{1, 1, 1, 3, 3, 3};
    return qs;
}

void expect_same_meshes(const MtModel& a, const MtModel& b, const Volume& v) {
    for (const LodQuery& q : queries(v)) {
        const TetMesh ma = a.extract(q), mb = b.extract(q);
        EXPECT_TRUE(ma.points == mb.points);
        EXPECT_TRUE(ma.tets == mb.tets);
    }
}

Expected<MtModel> load(std::span<const std::byte> f) {
    auto r = ContainerReader::from_memory(f);
    if (!r) return r.failure();
    return decode_mt_container(*r);
}

/// Everything the file holds, as `verify` reads it: the MT, and the HT with its
/// errors when there is one (loading the MT alone skips HT_ERRORS, by design).
bool reads_whole(std::span<const std::byte> f) {
    if (!load(f).ok()) return false;
    auto r = ContainerReader::from_memory(f);
    if (!(r->header().required_features & kFeatureHt)) return true;
    return decode_ht(*r).ok();
}

}  // namespace

TEST(MtContainer, RoundTripWithHtAndAlone) {
    for (ValueType t : {ValueType::U8, ValueType::I16, ValueType::F32}) {
        SCOPED_TRACE(value_type_name(t));
        const Fixture f = make({9, 7, 6}, t);
        // Reference: the built MT through its own codec (errors rounded up, m = 7).
        auto ref = decode_mt(encode_mt(f.mt, MtEncodeOptions{.include_field = true}));
        ASSERT_TRUE(ref.ok());
        for (const auto* file : {&f.both, &f.mt_only}) {
            auto m = load(*file);
            ASSERT_TRUE(m.ok()) << m.failure().message;
            EXPECT_TRUE(m->field().data == f.vol.data);
            EXPECT_TRUE(m->base_tets() == f.mt.base_tets());
            expect_same_meshes(*m, *ref, f.vol);
            LodQuery full_query;
            full_query.full = true;
            const TetMesh full = m->extract(full_query);
            EXPECT_EQ(int64_t(full.tet_count()), 5 * int64_t(8 * 6 * 5));
        }
        // Features: optional next to an HT, required alone; the HT still decodes.
        auto rb = ContainerReader::from_memory(f.both);
        ASSERT_TRUE(rb.ok());
        EXPECT_EQ(rb->header().required_features, kFeatureHt | kFeatureCompactTable);  // 3.2 table by default
        EXPECT_EQ(rb->header().optional_features, kFeatureMt);
        auto v = decode_volume(*rb);
        ASSERT_TRUE(v.ok()) << v.failure().message;
        EXPECT_TRUE(v->data == f.vol.data);
        auto ro = ContainerReader::from_memory(f.mt_only);
        ASSERT_TRUE(ro.ok());
        EXPECT_EQ(ro->header().required_features, kFeatureMt | kFeatureCompactTable);
        EXPECT_EQ(read_ht_layout(*ro).failure().code, ErrorCode::NotFound);
        // An HT-only file has no MT.
        ContainerWriter w;
        encode_ht(HtModel::build(f.vol), metadata_for_volume(f.vol), w);
        EXPECT_EQ(load(w.finish()).failure().code, ErrorCode::NotFound);
    }
}

TEST(MtContainer, EveryPrefixFailsCleanly) {
    const Fixture f = make({6, 5, 4}, ValueType::U8);
    for (const auto* file : {&f.both, &f.mt_only})
        for (std::size_t n = 0; n < file->size(); ++n)
            EXPECT_FALSE(load(std::span<const std::byte>(file->data(), n)).ok()) << "prefix " << n;
}

TEST(MtContainer, EverySingleBitFlipIsDetected) {
    const Fixture f = make({6, 5, 4}, ValueType::U8);
    for (const auto* file : {&f.both, &f.mt_only})
        for (std::size_t i = 0; i < file->size(); ++i)
            for (int b = 0; b < 8; ++b) {
                auto g = *file;
                g[i] ^= std::byte(uint8_t(1u << b));
                EXPECT_FALSE(reads_whole(g)) << "byte " << i << " bit " << b;
            }
}

namespace {

/// Expected contents of an MT test vector: counts and the tet counts of three
/// extractions, as text (compared verbatim).
std::string mt_summary(const MtModel& m) {
    std::ostringstream o;
    const auto r = m.field().range();
    o << "{\n  \"base_tets\": " << m.base_tets().size() << ",\n  \"updates\": " << m.updates().size() << ",\n";
    LodQuery full_query;
    full_query.full = true;
    o << "  \"tets_full\": " << m.extract(full_query).tet_count() << ",\n";
    LodQuery q0;
    q0.error_in = 0.0;
    o << "  \"tets_error_0\": " << m.extract(q0).tet_count() << ",\n";
    LodQuery q1;
    q1.error_in = 0.1 * (r[1] - r[0]);
    o << "  \"tets_error_10pct_of_range\": " << m.extract(q1).tet_count() << "\n}\n";
    return o.str();
}

}  // namespace

// spec/test-vectors/{ht_mt,mt}_v2.1_*: NAME.tlod, NAME.raw (the field), NAME.mt.json
// (what the MT holds and extracts). Written by the 2.1 writer; kept.
TEST(TestVectors, MtVectorsDecodeToTheirStoredContents) {
    const std::string dir = std::string(TETLOD_SPEC_DIR) + "/test-vectors/";
    struct V { const char* name; bool with_ht; bool current; double lossy = 0; };
    // Format 2.1 vectors (MT_Coding 1) are kept as written: a 3.0 writer would
    // write a 3.0 file (its HT in chunk modes), so they are no longer
    // regenerated. The 3.4 vectors (MT_Coding 3) and the 3.5 one (LOSSY_MT) are
    // kept as written too since 3.6: only the newest version's vectors are
    // regenerated (a 3.6 writer may code an ht_mt vector's HT field chunks in
    // range-2d). A vector marked `current` is regenerated with
    // TETLOD_REGENERATE_VECTORS=1, after a deliberate MT format change.
    for (const V v : {V{"ht_mt_v2.1_u8_9x6x5", true, false}, V{"mt_v2.1_i16_6x5x4", false, false},
                      V{"ht_mt_v3.4_u8_9x6x5", true, false}, V{"mt_v3.4_i16_6x5x4", false, false},
                      V{"ht_mt_lossy_v3.5_u8_9x6x5", true, false, 3.0}}) {
        const std::string base = dir + v.name;
        if (v.lossy > 0 && v.current && std::getenv("TETLOD_REGENERATE_VECTORS")) {
            // Format 3.5 (LOSSY_MT): the library's lossy writer, HT and MT over the stored field.
            Volume vol = tlodtest::make_volume(Dims{9, 6, 5}, ValueType::U8, 42);
            vol.metadata["sample.purpose"] = "tlod lossy MT test vector";
            ContainerWriteOptions o;
            o.mt = true;
            o.max_error = v.lossy;
            o.brick_log2 = 1;
            o.created = 0;
            write_container(std::move(vol), base + ".tlod", o);
            const MtModel m = load_mt_model(base + ".tlod");
            write_file_atomic(base + ".raw", m.field().data.data(), m.field().data.size());  // the stored field
            const std::string js = mt_summary(m);
            write_file_atomic(base + ".mt.json", js.data(), js.size());
        } else if (v.current && std::getenv("TETLOD_REGENERATE_VECTORS")) {
            Volume vol = tlodtest::make_volume(v.with_ht ? Dims{9, 6, 5} : Dims{6, 5, 4},
                                               v.with_ht ? ValueType::U8 : ValueType::I16, 42);
            vol.metadata["sample.purpose"] = "tlod MT test vector";
            Metadata meta = metadata_for_volume(vol);
            meta.format_keys[kKeyConverter] = "tests/format/test_mt_container.cpp";
            ContainerWriter w;
            if (v.with_ht) {
                HtEncodeOptions eo;
                eo.brick_log2 = 1;
                encode_ht(HtModel::build(vol), meta, w, eo);
            }
            const MtModel mt = MtModel::build(vol);
            encode_mt_container(mt, meta, w, v.with_ht);
            w.write(base + ".tlod");
            write_file_atomic(base + ".raw", vol.data.data(), vol.data.size());
            const std::string js = mt_summary(load_mt_model(base + ".tlod"));
            write_file_atomic(base + ".mt.json", js.data(), js.size());
        }
        if (!std::filesystem::exists(base + ".tlod")) GTEST_SKIP() << "no MT test vectors in " << dir;
        const MtModel m = load_mt_model(base + ".tlod");
        std::ifstream raw(base + ".raw", std::ios::binary), js(base + ".mt.json");
        const std::string rs((std::istreambuf_iterator<char>(raw)), {}), jss((std::istreambuf_iterator<char>(js)), {});
        ASSERT_EQ(rs.size(), m.field().data.size());
        EXPECT_EQ(0, std::memcmp(rs.data(), m.field().data.data(), rs.size())) << v.name;
        EXPECT_EQ(jss, mt_summary(m)) << v.name;
        auto r = ContainerReader::open(base + ".tlod").take();
        EXPECT_EQ((r.header().required_features & kFeatureLossyMt) != 0, v.lossy > 0) << v.name;
        // A lossy file's reference tets state E; its update errors include it (stored so).
        EXPECT_EQ(m.field_error_bound(), float(v.lossy)) << v.name;
        if (v.lossy > 0) {
            EXPECT_EQ(r.header().version_minor, 5);
            for (const MtSplit& u : m.updates()) EXPECT_GE(u.error, v.lossy);
        }
    }
}
