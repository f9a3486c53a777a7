// The format tables are the only place formats are listed: a format registered
// here (a test-only one, as a third party's would be) is read, written, named
// in help texts and accepted by --format with no other change anywhere.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "format_test_util.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/converters/volume_formats.hpp"

using namespace tetlod;
using namespace tetlod::test;

namespace {

// "Text volume": dims on the first line, then one sample per line (u8 only).
VolumeFormat text_volume_format() {
    VolumeFormat f;
    f.name = "txtvol";
    f.extensions = {".txtvol"};
    f.description = "test-only text volume";
    f.read = [](const VolumeLocation& l, const VolumeReadOptions&) {
        std::ifstream in(l.file);
        Dims d{};
        in >> d.x >> d.y >> d.z;
        Volume v = Volume::allocate(d, ValueType::U8);
        for (int64_t i = 0; i < d.count(); ++i) {
            int x = 0;
            in >> x;
            v.data[std::size_t(i)] = std::byte(x);
        }
        return v;
    };
    f.write = [](const Volume& v, const VolumeLocation& l) {
        std::ofstream out(l.file);
        out << v.dims[0] << ' ' << v.dims[1] << ' ' << v.dims[2] << '\n';
        for (std::byte b : v.data) out << std::to_integer<int>(b) << '\n';
    };
    return f;
}

}  // namespace

TEST(FormatRegistry, ATestFormatNeedsOnlyItsEntry) {
    register_volume_format(text_volume_format());
    EXPECT_TRUE(volume_format_built("txtvol"));
    const auto names = volume_format_names();
    EXPECT_NE(std::find(names.begin(), names.end(), "txtvol"), names.end());
    EXPECT_NE(volume_format_summary().find(".txtvol"), std::string::npos);

    const std::string dir = tmp_dir("registry");
    Volume v = Volume::allocate({3, 2, 2}, ValueType::U8);
    for (std::size_t i = 0; i < v.data.size(); ++i) v.data[i] = std::byte(7 * i);
    write_volume(v, dir + "/a.TXTVOL");
    const Volume r = read_volume(dir + "/a.TXTVOL");
    EXPECT_EQ(r.dims, v.dims);
    EXPECT_EQ(r.data, v.data);
    // ... and through the other formats, by the dispatcher alone.
    write_volume(r, dir + "/a.nrrd");
    EXPECT_EQ(read_volume(dir + "/a.nrrd").data, v.data);

    // Taken names and extensions are refused.
    expect_error([] { register_volume_format(text_volume_format()); }, ErrorCode::InvalidArgument, {"txtvol"});
    VolumeFormat clash = text_volume_format();
    clash.name = "other";
    clash.extensions = {".NRRD"};
    expect_error([&] { register_volume_format(clash); }, ErrorCode::InvalidArgument, {".nrrd"});
}

TEST(FormatRegistry, NotBuiltFormatsSaySo) {
    VolumeFormat f;
    f.name = "absent";
    f.extensions = {".absent"};
    f.built = false;
    f.not_built_hint = "the absent library";
    register_volume_format(f);
    EXPECT_FALSE(volume_format_built("absent"));
    EXPECT_NE(volume_format_summary().find(".absent (not built)"), std::string::npos);
    expect_error([] { read_volume("x.absent"); }, ErrorCode::NotBuilt, {"the absent library"});
}

TEST(FormatRegistry, ATestMeshFormatNeedsOnlyItsEntry) {
    MeshFormat f;
    f.name = "count";
    f.extensions = {".count"};
    f.description = "(tet count)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) {
        std::ofstream(path) << m.tets.size() << '\n';
    };
    f.companion_files = [](const std::string& path) { return std::vector<std::string>{path + ".side"}; };
    register_mesh_format(f);
    TetMesh m;
    m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    m.values = {0, 1, 2, 3};
    m.tets = {{0, 1, 2, 3}};
    const std::string dir = tmp_dir("registry_mesh");
    write_tet_mesh(m, dir + "/m.count");
    std::ifstream in(dir + "/m.count");
    int n = 0;
    in >> n;
    EXPECT_EQ(n, 1);
    const auto names = mesh_format_names();
    EXPECT_NE(std::find(names.begin(), names.end(), "count"), names.end());
    EXPECT_NE(mesh_format_summary().find(".count (tet count)"), std::string::npos);
    EXPECT_EQ(mesh_companion_files("a/m.count"), std::vector<std::string>{"a/m.count.side"});
    EXPECT_EQ(mesh_companion_files("a/m.mesh"), std::vector<std::string>{"a/m.sol"});
    EXPECT_EQ(volume_companion_files("a/v.nhdr"), std::vector<std::string>{"a/v.raw"});
    EXPECT_EQ(volume_companion_files("a/v.nhdr", "nrrd"), std::vector<std::string>{});
    EXPECT_EQ(volume_companion_files("a/v.bin", "mhd"), std::vector<std::string>{"a/v.raw"});
    EXPECT_TRUE(volume_companion_files("a/v.mha").empty());
}
