// The real files in the shared data folder, written by the real libraries and
// tools (h5py/HDF5, pyopenvdb/OpenVDB, VTK's NRRD and MetaImage headers), must
// convert to the same container as their raw originals: the same volume gives the
// same HT, whatever format carried it. Only the geometry and samples go into the
// compared containers' metadata, so provenance (file names, attributes) cannot
// make them differ.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/converters/volume_formats.hpp"
#include "tetlod/format/metadata.hpp"

namespace fs = std::filesystem;
using namespace tetlod;

namespace {

const fs::path kData = TETLOD_SHARED_DATA;

std::vector<char> slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Converts a volume file to a container whose metadata holds only what the
/// samples and the grid define; returns the container's bytes. A raw file knows
/// no geometry: it takes the spacing and origin of the file it is compared with.
std::vector<char> container_of(const std::string& input, const std::string& tag,
                               const Volume* geometry_from = nullptr) {
    VolumeReadOptions options;
    if (geometry_from) {
        options.spacing = geometry_from->spacing;
        options.origin = geometry_from->origin;
    }
    Volume v = read_volume(input, options);
    tlod::Metadata meta;
    meta.dims = v.dims;
    meta.type = v.type;
    meta.spacing = v.spacing;
    meta.origin = v.origin;
    meta.value_range = v.range();
    const fs::path out = fs::path(TETLOD_TEST_TMP) / ("real_" + tag + ".tlod");
    HtModel model = HtModel::build(std::move(v));
    write_ht_container(out.string(), model, meta);
    return slurp(out);
}

struct Pair {
    const char* name;
    const char* raw;
    const char* other;  // relative to the data folder (HDF5: with the dataset path)
};

void PrintTo(const Pair& p, std::ostream* os) { *os << p.name; }

class RealToContainer : public ::testing::TestWithParam<Pair> {};

TEST_P(RealToContainer, SameContainerAsTheRawOriginal) {
    const Pair& p = GetParam();
    if (!fs::exists(kData / p.raw))
        GTEST_SKIP() << "shared data not found at " << kData << " (see its MANIFEST.md)";
    const std::string other = (kData / p.other).string();
    const Volume geometry = read_volume(other, VolumeReadOptions{});
    const std::vector<char> a =
        container_of((kData / p.raw).string(), std::string(p.name) + "_raw", &geometry);
    const std::vector<char> b = container_of(other, std::string(p.name) + "_other");
    ASSERT_FALSE(a.empty());
    EXPECT_EQ(a.size(), b.size()) << p.other;
    EXPECT_TRUE(a == b) << p.other << " does not convert to the same container as " << p.raw;
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, RealToContainer,
    ::testing::Values(
        Pair{"bucky_h5", "bucky_32x32x32_uint8.raw", "bucky_32x32x32_uint8.h5:/volume"},
        Pair{"bucky_vdb", "bucky_32x32x32_uint8.raw", "bucky_32x32x32_uint8.vdb"},
        Pair{"headsq_h5", "headsq_64x64x93_int16.raw", "headsq_64x64x93_int16.h5:/volume"},
        Pair{"headsq_vdb", "headsq_64x64x93_int16.raw", "headsq_64x64x93_int16.vdb"},
        Pair{"headsq_nhdr", "headsq_64x64x93_int16.raw", "original/headsq/quarter.nhdr"},
        Pair{"head_mr_mhd", "head_mr_48x62x42_uint8.raw", "original/HeadMRVolume.mhd"},
        Pair{"m4_h5", "m4_total_density_25x22x31_float32.raw",
             "m4_total_density_25x22x31_float32.h5:/volume"},
        Pair{"m4_vdb", "m4_total_density_25x22x31_float32.raw",
             "m4_total_density_25x22x31_float32.vdb"},
        Pair{"neghip_vdb", "neghip_64x64x64_uint8.raw", "neghip_64x64x64_uint8.vdb"}),
    [](const auto& info) { return std::string(info.param.name); });

}  // namespace
