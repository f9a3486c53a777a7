// The public API end to end, through the umbrella header only: build both
// models from a generated volume, write a container, open it again, query it
// (uniform, box, isovalue), cut an isosurface, measure, verify, write a mesh;
// and a damaged container reports an Error naming the file.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "tetlod/tetlod.hpp"

namespace {

namespace fs = std::filesystem;
using namespace tetlod;

std::string tmp(const std::string& name) { return std::string(TETLOD_TEST_TMP) + "/" + name; }

Volume sample() { return make_sample_volume("marschner-lobb", Dims{17, 17, 17}); }

std::vector<LodQuery> queries(const std::array<double, 2>& range) {
    const double span = range[1] - range[0];
    LodQuery uniform;
    uniform.error_in = 0.05 * span;
    LodQuery box;
    box.error_in = 0.0;
    box.box = std::array<int64_t, 6>{2, 2, 2, 9, 9, 9};
    LodQuery iso;
    iso.error_in = 0.0;
    iso.isovalues = {range[0] + 0.5 * span};
    return {uniform, box, iso};
}

void expect_same_mesh(const TetMesh& a, const TetMesh& b) {
    EXPECT_EQ(a.tet_count(), b.tet_count());
    EXPECT_EQ(a.points, b.points);
    EXPECT_EQ(a.values, b.values);
    EXPECT_EQ(a.tets, b.tets);
}

// The README's example, compiled (not run: it names files that do not exist).
[[maybe_unused]] void readme_example() {
    LodModel ht = build_model(ModelKind::Ht, read_volume_file("ct.nrrd").take());
    ContainerWriteOptions o;
    o.mt = true;
    write_container(read_volume_file("ct.nrrd").take(), "ct.tlod", o);
    LodModel mt = open_model("ct.tlod", ModelKind::Mt).take();
    LodQuery q;
    q.error_in = 2.0;
    q.isovalues = {100};
    write_tet_mesh(mt.extract(q), "lod.vtu");
    VerifyReport r = verify_container("ct.tlod", /*deep=*/true);
    (void)ht, (void)r;
}

TEST(PublicApi, VersionsAreSeparate) {
    EXPECT_EQ(std::string(library_version()), std::to_string(TETLOD_VERSION_MAJOR) + "." +
                                                  std::to_string(TETLOD_VERSION_MINOR) + "." +
                                                  std::to_string(TETLOD_VERSION_PATCH));
    EXPECT_NE(std::string(format_version()).find("tlod"), std::string::npos);
}

TEST(PublicApi, BuildWriteOpenQueryMeasure) {
    const LodModel ht = build_model(ModelKind::Ht, sample());
    const LodModel mt = build_model(ModelKind::Mt, sample());
    EXPECT_EQ(ht.kind, ModelKind::Ht);
    EXPECT_EQ(mt.kind, ModelKind::Mt);
    EXPECT_EQ(ht.dims.x, 17);
    EXPECT_EQ(ht.range, mt.range);
    EXPECT_GT(ht.memory_bytes, 0u);

    const std::string path = tmp("api.tlod");
    ContainerWriteOptions wo;
    wo.ht = wo.mt = true;
    const ContainerWriteSummary written = write_container(sample(), path, wo);
    EXPECT_EQ(written.bytes, fs::file_size(path));
    EXPECT_EQ(written.ht_k, 4);
    EXPECT_GT(written.mt_updates, 0u);

    const ContainerModels held = container_models(path);
    EXPECT_TRUE(held.ht && held.mt);
    EXPECT_TRUE(is_container_path(path));
    const ContainerInfo info = inspect_container(path).take();
    ASSERT_TRUE(info.ht && info.mt);
    EXPECT_EQ(info.metadata.dims.x, 17);
    EXPECT_FALSE(info.ht->cycles.empty());

    const Volume decoded = decode_container(path).take();
    EXPECT_EQ(decoded.data, sample().data);

    for (const ModelKind kind : {ModelKind::Ht, ModelKind::Mt}) {
        const LodModel& built = kind == ModelKind::Ht ? ht : mt;
        const LodModel opened = open_model(path, kind).take();
        const StoredModel stored = open_stored_model(path, kind).take();
        EXPECT_EQ(stored.volume.data, decoded.data);
        EXPECT_EQ(stored.model.range, built.range);
        EXPECT_TRUE(opened.from_container);
        EXPECT_EQ(opened.range, built.range);
        for (const LodQuery& q : queries(built.range)) {
            const TetMesh from_memory = built.extract(q);
            EXPECT_GT(from_memory.tet_count(), 0u);
            expect_same_mesh(opened.extract(q), from_memory);
            const ContainerExtract x = extract_from_container(path, kind, q).take();
            expect_same_mesh(x.mesh, from_memory);
            if (kind == ModelKind::Ht) {  // the lazy HT path: the file's bytes it touched, each once
                EXPECT_GT(x.distinct_bytes_read, 0u);
                EXPECT_LE(x.distinct_bytes_read, x.file_size);
                EXPECT_GE(x.bytes_read, x.distinct_bytes_read);
            }
        }
    }

    // Isosurface on the isovalue query's mesh.
    const LodQuery iso = queries(ht.range)[2];
    const TriangleMesh surface = ht.isosurface(iso, iso.isovalues);
    EXPECT_GT(surface.face_count(), 0u);

    // Statistics: one row per threshold and query type.
    StatsOptions so;
    so.error_fractions = {0.01, 0.1};
    const ModelStats stats = measure_model(ht, "HT", so);
    EXPECT_EQ(stats.uniform.size(), 2u);
    EXPECT_EQ(stats.full_tets, 6u * 16 * 16 * 16);
    EXPECT_EQ(stats_json({stats}).size(), 1u);
    EXPECT_NE(stats_text({stats}).find("full mesh"), std::string::npos);

    // Verification, deep.
    const VerifyReport rep = verify_container(path, true);
    EXPECT_TRUE(rep.ok()) << rep.failure->message;
    EXPECT_TRUE(rep.ht_deep_ok && rep.mt_deep_ok);

    // LOD deviation within the query's bound.
    const LodQuery uniform = queries(ht.range)[0];
    const LodVolume lod = lod_volume(ht.extract(uniform), decoded);
    EXPECT_LE(lod.deviation.max, uniform.error_in + 0.5);  // u8: rounded to nearest

    // A mesh file.
    const std::string vtu = tmp("api.vtu");
    write_tet_mesh(ht.extract(uniform), vtu);
    EXPECT_GT(fs::file_size(vtu), 0u);
}

// --mt-error-bits: the MT's stored bounds are rounded up to fewer mantissa
// bits, so the file shrinks while every LOD still honours its error against
// the volume at every grid point (never fewer tets than the finer bounds give).
TEST(PublicApi, MtErrorBitsRoundStoredBoundsUp) {
    const Volume volume = make_sample_volume("multiscale", Dims{21, 19, 17});
    const std::string fine = tmp("mt_bits7.tlod"), coarse = tmp("mt_bits3.tlod");
    ContainerWriteOptions wo;
    wo.ht = false;
    wo.mt = true;
    write_container(volume, fine, wo);
    wo.mt_error_bits = 3;
    write_container(volume, coarse, wo);
    EXPECT_EQ(inspect_container(fine).take().mt->error_mantissa_bits, 7);
    EXPECT_EQ(inspect_container(coarse).take().mt->error_mantissa_bits, 3);
    EXPECT_LT(fs::file_size(coarse), fs::file_size(fine));

    const LodModel a = open_model(fine, ModelKind::Mt).take();
    const LodModel b = open_model(coarse, ModelKind::Mt).take();
    const double span = a.range[1] - a.range[0];
    bool some_larger = false;
    for (const double f : {0.001, 0.01, 0.03, 0.1}) {
        LodQuery q;
        q.error_in = f * span;
        const TetMesh ma = a.extract(q), mb = b.extract(q);
        EXPECT_GE(mb.tet_count(), ma.tet_count()) << f;
        some_larger = some_larger || mb.tet_count() > ma.tet_count();
        EXPECT_LE(lod_volume(mb, volume).deviation.max, q.error_in + 0.5) << f;  // u8: rounded
    }
    EXPECT_TRUE(some_larger);  // coarser bounds do refine more somewhere
    const VerifyReport rep = verify_container(coarse, true);
    EXPECT_TRUE(rep.ok()) << rep.failure->message;

    wo.mt_error_bits = 8;
    try {
        write_container(volume, tmp("mt_bits8.tlod"), wo);
        ADD_FAILURE() << "8 mantissa bits accepted";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
    }
    EXPECT_FALSE(fs::exists(tmp("mt_bits8.tlod")));
    wo.mt_error_bits = 7;
    for (const int level : {-1, 23}) {
        wo.mt_large_stream_zstd_level = level;
        try {
            write_container(volume, tmp("mt_large_level.tlod"), wo);
            ADD_FAILURE() << "MT large-stream level " << level << " accepted";
        } catch (const Error& e) {
            EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
        }
        EXPECT_FALSE(fs::exists(tmp("mt_large_level.tlod")));
    }
}

TEST(PublicApi, CorruptContainerIsAnErrorNamingTheFile) {
    const std::string good = tmp("good.tlod"), bad = tmp("corrupt.tlod");
    write_container(sample(), good);
    std::string bytes;
    {
        std::ifstream in(good, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    ASSERT_GT(bytes.size(), 200u);
    bytes[bytes.size() / 2] ^= 0x5a;  // inside a section: its checksum fails
    {
        std::ofstream out(bad, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), std::streamsize(bytes.size()));
    }
    const VerifyReport rep = verify_container(bad, false);
    ASSERT_FALSE(rep.ok());
    EXPECT_NE(rep.failure->message.find(bad), std::string::npos) << rep.failure->message;

    const auto model = open_model(bad, ModelKind::Ht);
    ASSERT_FALSE(model.ok());
    EXPECT_NE(model.failure().message.find(bad), std::string::npos) << model.failure().message;
    const auto volume = decode_container(bad);
    ASSERT_FALSE(volume.ok());
    EXPECT_NE(volume.failure().message.find(bad), std::string::npos);
    EXPECT_THROW(decode_container(bad).take(), Error);

    const auto missing = inspect_container(tmp("missing.tlod"));
    ASSERT_FALSE(missing.ok());
    EXPECT_NE(missing.failure().message.find("missing.tlod"), std::string::npos);
}

}  // namespace
