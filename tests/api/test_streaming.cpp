// Streamed extraction (LodModel::extract_to, extract_from_container_to, a
// writer from open_mesh_stream) writes the very bytes of extracting the whole
// mesh and writing it (write_tet_mesh), for every format and kind of query,
// from memory and from a container, with meshes large enough to come in many
// batches; a sink that is misused leaves no file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "tetlod/tetlod.hpp"

namespace {

namespace fs = std::filesystem;
using namespace tetlod;

std::string tmp(const std::string& name) { return std::string(TETLOD_TEST_TMP) + "/stream_" + name; }

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

std::vector<LodQuery> queries(const std::array<double, 2>& range, const Dims& d) {
    const double span = range[1] - range[0];
    std::vector<LodQuery> qs(5);
    qs[0].error_in = 0.05 * span;
    qs[1].error_in = 0.002 * span;
    qs[2].full = true;  // every grid cube: many batches of tets, many compressed blocks
    qs[3].error_in = 0.0;
    qs[3].error_out = 0.2 * span;
    qs[3].box = std::array<int64_t, 6>{2, 3, 4, d.x / 2, d.y / 2, d.z - 2};
    qs[4].error_in = 0.0;
    qs[4].error_out = 0.3 * span;
    qs[4].isovalues = {range[0] + 0.4 * span};
    return qs;
}

struct Format {
    std::string name, ext;
    MeshWriteOptions options;
};

std::vector<Format> formats() {
    std::vector<Format> f;
    for (auto c : {MeshCompression::Zlib, MeshCompression::Lz4, MeshCompression::Lzma, MeshCompression::None}) {
        MeshWriteOptions o;
        o.compression = c;
        f.push_back({"vtu", ".vtu", o});
    }
    f.push_back({"vtk", ".vtk", {}});
    f.push_back({"msh", ".msh", {}});
    f.push_back({"msh-binary", ".msh", {}});
    f.push_back({"mesh", ".mesh", {}});
    return f;
}

void expect_same_files(const std::string& a, const std::string& b, const std::string& what) {
    ASSERT_TRUE(fs::exists(a)) << what;
    ASSERT_TRUE(fs::exists(b)) << what;
    const std::string x = slurp(a), y = slurp(b);
    EXPECT_EQ(x.size(), y.size()) << what;
    EXPECT_TRUE(x == y) << what << ": streamed file differs";
    for (const auto& companion : mesh_companion_files(a)) {
        const auto other = mesh_companion_files(b);
        ASSERT_FALSE(other.empty());
        EXPECT_TRUE(slurp(companion) == slurp(other[0])) << what << ": " << companion;
    }
}

void clean(const std::string& path) {
    for (const auto& c : mesh_companion_files(path)) fs::remove(c);
    fs::remove(path);
}

TEST(Streaming, InMemoryModelsWriteTheSameBytes) {
    const Dims d{41, 34, 29};
    for (ModelKind kind : {ModelKind::Ht, ModelKind::Mt}) {
        // The MT hands a whole mesh over: a smaller volume suffices.
        const Dims dims = kind == ModelKind::Ht ? d : Dims{13, 11, 9};
        const LodModel model = build_model(kind, make_sample_volume("marschner-lobb", dims));
        const auto qs = queries(model.range, dims);
        for (std::size_t q = 0; q < qs.size(); ++q)
            for (const Format& f : formats()) {
                const std::string what = std::string(kind == ModelKind::Ht ? "ht" : "mt") + " query " +
                                         std::to_string(q) + " " + f.name + " " +
                                         mesh_compression_name(f.options.compression);
                const std::string a = tmp("whole" + f.ext), b = tmp("streamed" + f.ext);
                clean(a), clean(b);
                write_tet_mesh(model.extract(qs[q]), a, f.name, f.options);
                auto sink = open_mesh_stream(b, f.name, f.options);
                TetMeshCounter counted(*sink);
                model.extract_to(qs[q], counted);
                EXPECT_EQ(counted.tets, model.extract(qs[q]).tet_count()) << what;
                expect_same_files(a, b, what);
                clean(a), clean(b);
            }
    }
}

TEST(Streaming, ContainerExtractionWritesTheSameBytes) {
    const Dims d{37, 30, 33};
    const std::string container = tmp("model.tlod");
    fs::remove(container);
    ContainerWriteOptions wo;
    wo.mt = true;
    write_container(make_sample_volume("marschner-lobb", d), container, wo);
    for (ModelKind kind : {ModelKind::Ht, ModelKind::Mt}) {
        const auto probe = extract_from_container(container, kind, LodQuery{}).take();
        const auto qs = queries(probe.range, d);
        for (std::size_t q = 0; q < qs.size(); ++q)
            for (const Format& f : {formats()[0], formats()[4], formats()[5]}) {
                const std::string what = std::string(kind == ModelKind::Ht ? "ht" : "mt") + " query " +
                                         std::to_string(q) + " " + f.name;
                const std::string a = tmp("cwhole" + f.ext), b = tmp("cstreamed" + f.ext);
                clean(a), clean(b);
                const auto whole = extract_from_container(container, kind, qs[q]).take();
                write_tet_mesh(whole.mesh, a, f.name, f.options);
                auto sink = open_mesh_stream(b, f.name, f.options);
                ContainerExtractOptions small_cache;
                small_cache.cache_bytes = 1 << 20;  // a few chunks: decoded again, same mesh
                const auto streamed =
                    extract_from_container_to(container, kind, qs[q], *sink, {}, small_cache).take();
                EXPECT_EQ(streamed.tet_count, whole.mesh.tet_count()) << what;
                EXPECT_EQ(streamed.vertex_count, whole.mesh.vertex_count()) << what;
                EXPECT_TRUE(streamed.mesh.tets.empty()) << what;
                expect_same_files(a, b, what);
                clean(a), clean(b);
            }
    }
    fs::remove(container);
}

TEST(Streaming, AMisusedSinkLeavesNoFile) {
    const LodModel model = build_model(ModelKind::Ht, make_sample_volume("marschner-lobb", Dims{9, 9, 9}));
    const TetMesh mesh = model.extract(LodQuery{});
    for (const Format& f : formats()) {
        const std::string path = tmp("misused" + f.ext);
        clean(path);
        {
            auto sink = open_mesh_stream(path, f.name, f.options);
            sink->begin(mesh, mesh.tets.size() + 1);  // one tet too many announced
            sink->add(mesh.tets, mesh.level, mesh.error);
            EXPECT_THROW(sink->finish(), Error) << f.name;
        }
        EXPECT_FALSE(fs::exists(path)) << f.name;
        {
            auto sink = open_mesh_stream(path, f.name, f.options);
            TetMesh bad = mesh;
            bad.tets[0][2] = uint32_t(mesh.points.size());  // a vertex that does not exist
            sink->begin(mesh, mesh.tets.size());
            try {
                sink->add(bad.tets, bad.level, bad.error);
                sink->finish();
                ADD_FAILURE() << f.name << ": a tet using a missing vertex was written";
            } catch (const Error& e) {
                EXPECT_EQ(e.code(), ErrorCode::InvalidArgument) << f.name;
            }
        }
        EXPECT_FALSE(fs::exists(path)) << f.name;
    }
}

}  // namespace
