#pragma once
// Checks shared by the tests of plane readers and of writers fed planes
// (NRRD/MetaImage, HDF5, OpenVDB, containers): the orders planes are read in,
// a reader's planes against the whole read of the same file, and planes that
// fail part-way. Header-only, public headers only (the API tests use it too).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod::test {

/// The planes 0 .. n-1 in three orders: forward, backward, and shuffled by
/// std::mt19937(seed).
inline std::vector<std::vector<int64_t>> plane_orders(int64_t n, unsigned seed) {
    std::vector<int64_t> forward(static_cast<std::size_t>(n));
    std::iota(forward.begin(), forward.end(), 0);
    std::vector<int64_t> backward(forward.rbegin(), forward.rend());
    std::vector<int64_t> shuffled = forward;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(seed));
    return {forward, backward, shuffled};
}

/// The bytes of every plane of `planes`, read one per call in `order` and each
/// placed at its z (a whole volume's samples when `order` covers every plane).
inline std::vector<std::byte> read_planes_in(VolumePlanes& planes, const std::vector<int64_t>& order) {
    const Volume& h = planes.header();
    const std::size_t plane = std::size_t(h.dims.x * h.dims.y) * value_size(h.type);
    std::vector<std::byte> out(plane * std::size_t(h.dims.z));
    for (int64_t z : order) planes.read(z, 1, out.data() + std::size_t(z) * plane);
    return out;
}

/// `planes` against `whole`, the whole read of the same file: the same header
/// (dims, type, geometry, names, metadata), and the same samples read one plane
/// per call in each order of plane_orders(dims.z, seed), all in one call, in
/// batches of three, and the last plane twice (padding repeats it); reads past
/// the last plane are refused.
inline void expect_planes_equal_whole(VolumePlanes& planes, const Volume& whole, unsigned seed) {
    const Volume& h = planes.header();
    ASSERT_EQ(h.dims, whole.dims);
    EXPECT_EQ(h.type, whole.type);
    EXPECT_EQ(h.spacing, whole.spacing);
    EXPECT_EQ(h.origin, whole.origin);
    EXPECT_EQ(h.field_name, whole.field_name);
    EXPECT_EQ(h.units, whole.units);
    EXPECT_EQ(h.metadata, whole.metadata);
    const std::size_t plane = std::size_t(h.dims.x * h.dims.y) * value_size(h.type);
    const auto same = [&](const std::vector<std::byte>& got) {
        return got.size() == whole.data.size() && std::equal(got.begin(), got.end(), whole.data.begin());
    };
    int how = 0;
    for (const auto& order : plane_orders(h.dims.z, seed))
        EXPECT_TRUE(same(read_planes_in(planes, order))) << "order " << how++;
    std::vector<std::byte> all(whole.data.size());
    planes.read(0, h.dims.z, all.data());
    EXPECT_TRUE(same(all)) << "all planes in one read";
    std::fill(all.begin(), all.end(), std::byte{0});
    for (int64_t z0 = 0; z0 < h.dims.z; z0 += 3)
        planes.read(z0, std::min<int64_t>(3, h.dims.z - z0), all.data() + std::size_t(z0) * plane);
    EXPECT_TRUE(same(all)) << "batches of three planes";
    planes.read(h.dims.z - 1, 1, all.data());
    planes.read(h.dims.z - 1, 1, all.data());
    EXPECT_TRUE(std::equal(all.begin(), all.begin() + std::ptrdiff_t(plane),
                           whole.data.begin() + std::ptrdiff_t((h.dims.z - 1) * int64_t(plane))))
        << "the last plane read twice";
    EXPECT_THROW(planes.read(h.dims.z, 1, all.data()), Error);
    EXPECT_THROW(planes.read(h.dims.z - 1, 2, all.data()), Error);
}

/// Planes of a volume described by `h` (its samples unused) whose reads
/// starting past plane `last_good` throw CorruptData naming 'src.tlod', as a
/// corrupt container met by a streaming decode; earlier reads leave `dst` as
/// it is. For the writers' "a failed read leaves nothing" tests.
struct FailingPlanes final : VolumePlanes {
    FailingPlanes(Volume header, int64_t good) : h(std::move(header)), last_good(good) { h.data = {}; }
    const Volume& header() const override { return h; }
    void read(int64_t z0, int64_t, std::byte*) override {
        if (z0 > last_good) throw Error(ErrorCode::CorruptData, "'src.tlod': bad chunk");
    }
    Volume h;
    int64_t last_good = 0;
};

}  // namespace tetlod::test
