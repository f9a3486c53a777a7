// The lazy extraction (one pass over a bounded cache of chunks decoded on their
// own) against the extraction from the fully decoded model: the same mesh,
// vertex for vertex and tet for tet, on awkward dims, every value type, small
// bricks (many chunks), the spec's test vectors of every format version, and
// caches from "nothing kept" to "everything kept".
#include <gtest/gtest.h>

#include <filesystem>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/lossy_field.hpp"
#include "tetlod/models/query_region.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;
using namespace tetlod::tlod;

namespace {

std::vector<LodQuery> queries_for(const HtModel& m) {
    const auto r = m.value_range();
    const double range = std::isfinite(r[1] - r[0]) ? r[1] - r[0] : 1.0;
    const Dims d = m.field().dims;
    std::vector<LodQuery> qs(7);
    qs[0].error_in = 0.2 * range;
    qs[1].error_in = 0.01 * range;
    qs[2].error_in = 0.0;
    qs[3].box = std::array<int64_t, 6>{d.x / 4, d.y / 3, d.z / 5, d.x / 2, d.y / 2 + 1, d.z - 1};
    qs[3].error_in = 0.0;
    qs[3].error_out = 0.3 * range;
    qs[4].isovalues = {r[0] + 0.5 * range};
    qs[4].error_in = 0.02 * range;
    qs[4].error_out = 0.5 * range;
    qs[5].full = true;
    qs[6].regions.push_back(
        find_query_region_kind("sphere")->parse(std::to_string(d.x / 2) + "," + std::to_string(d.y / 3) + ",1," +
                                         std::to_string(std::max<int64_t>(2, d.z / 3))));
    qs[6].error_in = 0.0;
    qs[6].error_out = 0.4 * range;
    return qs;
}

void expect_same(const TetMesh& got, const TetMesh& want, const std::string& what) {
    EXPECT_EQ(got.points, want.points) << what;
    EXPECT_EQ(got.tets, want.tets) << what;
    EXPECT_EQ(got.level, want.level) << what;
    ASSERT_EQ(got.values.size(), want.values.size()) << what;
    for (std::size_t i = 0; i < got.values.size(); ++i)
        if (!(std::isnan(got.values[i]) && std::isnan(want.values[i]))) {
            ASSERT_EQ(got.values[i], want.values[i]) << what << " vertex " << i;
        }
    EXPECT_EQ(got.error, want.error) << what;
    EXPECT_EQ(got.value_type, want.value_type) << what;
    EXPECT_EQ(got.geometry.spacing, want.geometry.spacing) << what;
}

/// Every query, with caches of a few chunks (chunks decoded again and again),
/// some tens of chunks, and the default (each chunk decoded once).
void check_container(const std::vector<std::byte>& file, const std::string& name) {
    auto rf = ContainerReader::from_memory(file);
    auto full = decode_ht(*rf);
    ASSERT_TRUE(full.ok()) << name << ": " << full.failure().message;
    HtModel ref = HtModel::from_parts(full->field, full->layout.domain, full->errors, full->layout.max_error);
    const auto qs = queries_for(ref);
    for (std::size_t q = 0; q < qs.size(); ++q) {
        const TetMesh want = ref.extract(qs[q]);
        for (std::size_t cache : {std::size_t{16} << 10, std::size_t{200} << 10, std::size_t{1} << 30}) {
            const std::string what = name + " query " + std::to_string(q) + " cache " + std::to_string(cache);
            auto r = ContainerReader::from_memory(file);
            HtLazyStats st;
            HtLazyOptions o;
            o.cache_bytes = cache;
            auto got = extract_ht_lazy(*r, qs[q], nullptr, &st, o);
            ASSERT_TRUE(got.ok()) << what << ": " << got.failure().message;
            expect_same(*got, want, what);
            EXPECT_EQ(st.passes, 1) << what;
            EXPECT_LE(st.chunks_decoded, st.chunks_total) << what;
            EXPECT_GE(st.chunk_decodes, st.chunks_decoded) << what;
            if (cache == std::size_t{1} << 30) {
                EXPECT_EQ(st.chunk_decodes, st.chunks_decoded) << what;
            }
        }
    }
}

struct Case {
    Dims dims;
    ValueType type;
    int brick_log2;
    bool pad;
};

// Names the case in ctest's list (the default prints the struct's bytes, padding
// included, which differ from build to build).
void PrintTo(const Case& c, std::ostream* os) {
    *os << c.dims.x << 'x' << c.dims.y << 'x' << c.dims.z << ' ' << value_type_name(c.type) << " brick_log2 "
        << c.brick_log2 << (c.pad ? " padded" : "");
}

class LazyExtractCases : public ::testing::TestWithParam<Case> {};

TEST_P(LazyExtractCases, SameMeshAsTheFullDecodeForEveryCache) {
    const Case c = GetParam();
    Volume v = tlodtest::make_volume(c.dims, c.type, 11, /*specials=*/false);
    HtBuildOptions bo;
    bo.pad = c.pad;
    HtModel built = HtModel::build(v, bo);
    ContainerWriter w;
    HtEncodeOptions eo;
    eo.brick_log2 = c.brick_log2;
    eo.zstd_level = 3;
    encode_ht(built, metadata_for_volume(v), w, eo);
    check_container(w.finish(), "case");
}

INSTANTIATE_TEST_SUITE_P(Awkward, LazyExtractCases,
                         ::testing::Values(Case{{33, 29, 31}, ValueType::U16, 2, false},
                                           Case{{2, 2, 2}, ValueType::U8, 1, false},
                                           Case{{18, 2, 7}, ValueType::I8, 1, false},
                                           Case{{17, 17, 17}, ValueType::F32, 1, false},
                                           Case{{40, 9, 23}, ValueType::F64, 1, false},
                                           Case{{21, 13, 6}, ValueType::I32, 3, true},
                                           Case{{65, 3, 5}, ValueType::U8, 2, false}));

// Lossy files whose field chunks are in the lattice mode (format 3.3, §6.4):
// each chunk decoded alone in its window through the cache, against the whole
// decode (whose bounds include E, as the lazy reader's).
TEST(LazyExtract, LossyLatticeChunks) {
    for (ValueType t : {ValueType::F32, ValueType::F64, ValueType::I16}) {
        Volume v = tlodtest::make_volume({29, 19, 23}, t, 13, /*specials=*/false);
        const double e = 2.0;
        quantize_volume(v, e);
        ContainerWriter w;
        HtEncodeOptions eo;
        eo.brick_log2 = 1;
        eo.zstd_level = 3;
        eo.max_error = e;
        eo.chunk_mode = 4;  // forced wherever it can code the chunk
        encode_ht(HtModel::build(v), metadata_for_volume(v), w, eo);
        const auto file = w.finish();
        auto r = ContainerReader::from_memory(file);
        int lattice = 0;
        for (const auto& s : r->sections()) lattice += s.type == kSectionHtField && section_mode(s.flags) == 4;
        ASSERT_GT(lattice, 0) << value_type_name(t);
        check_container(file, std::string("lossy lattice ") + value_type_name(t));
    }
}

TEST(LazyExtract, SpecTestVectorsOfEveryVersion) {
    const std::filesystem::path dir = std::filesystem::path(TETLOD_SPEC_DIR) / "test-vectors";
    int n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        if (e.path().extension() != ".tlod" || e.path().filename().string().rfind("ht_", 0) != 0) continue;
        auto r = ContainerReader::open(e.path().string());
        ASSERT_TRUE(r.ok()) << e.path();
        std::vector<std::byte> file(std::filesystem::file_size(e.path()));
        {
            std::FILE* f = std::fopen(e.path().c_str(), "rb");
            ASSERT_NE(f, nullptr);
            ASSERT_EQ(std::fread(file.data(), 1, file.size(), f), file.size());
            std::fclose(f);
        }
        check_container(file, e.path().filename().string());
        ++n;
    }
    EXPECT_GE(n, 6) << "test vectors of format 1 and 2 expected in " << dir;
}

// A corrupt chunk met halfway through the refinement is a clean error naming
// the container and the section.
TEST(LazyExtract, CorruptChunkIsACleanError) {
    Volume v = tlodtest::make_volume({33, 17, 9}, ValueType::U8, 3);
    HtModel built = HtModel::build(v);
    ContainerWriter w;
    HtEncodeOptions eo;
    eo.brick_log2 = 1;
    encode_ht(built, metadata_for_volume(v), w, eo);
    auto file = w.finish();
    auto r0 = ContainerReader::from_memory(file);
    auto layout = read_ht_layout(*r0);
    ASSERT_TRUE(layout.ok());
    // Garble the last (finest) chunk's field section; its checksum catches it.
    const auto& sec = r0->sections()[layout->chunks.back().field_section];
    file[std::size_t(sec.offset + sec.stored_size / 2)] ^= std::byte{0x5A};
    auto r = ContainerReader::from_memory(file);
    LodQuery q;
    q.error_in = 0.0;
    auto got = extract_ht_lazy(*r, q);
    ASSERT_FALSE(got.ok());
    EXPECT_TRUE(got.failure().code == ErrorCode::ChecksumMismatch || got.failure().code == ErrorCode::CorruptData)
        << got.failure().message;
    EXPECT_NE(got.failure().message.find("section"), std::string::npos) << got.failure().message;
}

}  // namespace
