// HDF5 volume reader and writer (HDF5 C library, 1.10 API). See
// tetlod/converters/hdf5.hpp for the axis and attribute conventions.
#include "tetlod/converters/hdf5.hpp"

#include <hdf5.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <set>

#include "hdf5_dataset.hpp"
#include "hdf5_dataset_write.hpp"
#include "hdf5_read_guard.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_volume.hpp"
#include "tetlod/core/regular_file.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/output_policy.hpp"

namespace tetlod {

using namespace hdf5_detail;

namespace {

constexpr std::size_t kSlabBytes = std::size_t{16} << 20;  // transposing reads and plane writes go through this much

// The read itself, in whichever process read_hdf5 chose.
Volume read_hdf5_here(const std::string& file, const std::string& dataset, const VolumeReadOptions& options,
                      uint64_t file_size) {
    const Hdf5Source src = open_hdf5_source(file, dataset, options, file_size, /*for_planes=*/false);
    Volume vol = Volume::allocate(src.header.dims, src.header.type);
    vol.spacing = src.header.spacing;
    vol.origin = src.header.origin;
    vol.field_name = src.header.field_name;
    vol.units = src.header.units;
    vol.metadata = src.header.metadata;
    const Dims dims = vol.dims;
    const int rank = src.rank;
    const std::string& what = src.what;
    const hid_t d = src.dataset.get();
    const hid_t mt = native_type(vol.type);
    if (!src.xyz) {
        // Same element order as the volume: one read straight into it. The library
        // converts byte order through its own bounded buffer (1 MiB by default)
        // and decodes chunks one at a time, so no extra copy of the volume exists.
        if (H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, vol.data.data()) < 0)
            throw Error(ErrorCode::CorruptData, what + ": cannot read the dataset: " + hdf5_error_text());
    } else {
        // Dataset [x][y][z]: read slabs of x planes, scatter them into x-fastest order.
        const std::size_t w = value_size(vol.type);
        const uint64_t plane = static_cast<uint64_t>(dims.y) * static_cast<uint64_t>(dims.z);
        const int64_t per = std::max<int64_t>(1, static_cast<int64_t>(kSlabBytes / (plane * w)));
        std::vector<std::byte> slab(static_cast<std::size_t>(std::min<int64_t>(per, dims.x) * plane * w));
        for (int64_t x0 = 0; x0 < dims.x; x0 += per) {
            int64_t nx = std::min<int64_t>(per, dims.x - x0);
            hsize_t start[3] = {static_cast<hsize_t>(x0), 0, 0};
            hsize_t count[3] = {static_cast<hsize_t>(nx), rank > 1 ? static_cast<hsize_t>(dims.y) : 1,
                                rank > 2 ? static_cast<hsize_t>(dims.z) : 1};
            Hid fs(H5Dget_space(d), H5Sclose);
            H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
            hsize_t mcount = static_cast<hsize_t>(nx) * plane;
            Hid ms(H5Screate_simple(1, &mcount, nullptr), H5Sclose);
            if (H5Dread(d, mt, ms.get(), fs.get(), H5P_DEFAULT, slab.data()) < 0)
                throw Error(ErrorCode::CorruptData, what + ": cannot read the dataset: " + hdf5_error_text());
            for (int64_t i = 0; i < nx; ++i)
                for (int64_t j = 0; j < dims.y; ++j)
                    for (int64_t k = 0; k < dims.z; ++k) {
                        const std::byte* src = slab.data() + ((i * dims.y + j) * dims.z + k) * w;
                        std::memcpy(vol.data.data() + dims.index(x0 + i, j, k) * w, src, w);
                    }
        }
    }
    return vol;
}

}  // namespace

Volume read_hdf5(const std::string& file, const std::string& dataset, const VolumeReadOptions& options) {
    require_regular_file(file, "HDF5 file");
    std::error_code ec;
    const uint64_t file_size = std::filesystem::file_size(file, ec);
    if (ec) throw Error(ErrorCode::IoError, "cannot open '" + file + "': " + ec.message());
    hdf5_guard::check_hdf5_superblock(file, file_size);
    if (!options.isolation.enabled) return read_hdf5_here(file, dataset, options, file_size);
    // libhdf5 crashes or loops on some corrupt files: it reads in a child process.
    IsolatedTask task{"the HDF5 library", file, isolation_time_limit(options.isolation, file_size),
                      isolation_memory_limit(options.isolation, file_size)};
    return read_volume_isolated(task, [&] { return read_hdf5_here(file, dataset, options, file_size); });
}

namespace {

// Writes the samples of the dataset just created (memory type: the volume's native type).
using FillDataset = std::function<void(hid_t dataset, hid_t memory_type, const std::string& what)>;

// write_hdf5 for a volume whose samples `fill` writes: `vol` gives the dims,
// type, geometry, names and metadata (its data is not read).
void write_hdf5_with(const Volume& vol, const std::string& file, const std::string& dataset_in,
                     const Hdf5WriteOptions& options, const FillDataset& fill) {
    const std::string dataset = normalize_dataset(dataset_in);
    const std::string what = name_of(file, dataset);
    validate_dims(vol.dims, what);
    if (options.deflate_level < 0 || options.deflate_level > 9)
        throw Error(ErrorCode::InvalidArgument, what + ": deflate level must be 0..9");
    silence_hdf5();

    // A temporary copy of the file (atomicity, other datasets kept), the
    // dataset, its samples, its attributes: the steps hdf5_dataset_write.cpp
    // shares with the parallel writer of tetlod-mpi (hdf5_mpi_write.cpp).
    OutputPolicy* policy = active_output_policy();
    StagedOutput out = stage_output(file, dataset, policy);
    {
        Hid f = open_output_file(out.path->temp_path(), out.update, H5P_DEFAULT, file, what);
        Hid d = create_volume_dataset(f.get(), file, dataset, vol, options, out.update, policy, what);
        fill(d.get(), native_type(vol.type), what);
        write_volume_attributes(d.get(), vol, what);
        if (H5Fflush(f.get(), H5F_SCOPE_GLOBAL) < 0)
            throw Error(ErrorCode::IoError, "cannot flush '" + file + "': " + hdf5_error_text());
    }
    out.path->commit();
}

}  // namespace

void write_hdf5(const Volume& vol, const std::string& file, const std::string& dataset,
                const Hdf5WriteOptions& options) {
    if (vol.data.size() != static_cast<std::size_t>(vol.dims.count()) * value_size(vol.type))
        throw Error(ErrorCode::InvalidArgument,
                    name_of(file, normalize_dataset(dataset)) + ": volume data size does not match its dims");
    write_hdf5_with(vol, file, dataset, options, [&](hid_t d, hid_t mt, const std::string& what) {
        if (H5Dwrite(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, vol.data.data()) < 0)
            throw Error(ErrorCode::IoError, what + ": cannot write the dataset: " + hdf5_error_text());
    });
}

void write_hdf5(VolumePlanes& planes, const std::string& file, const std::string& dataset,
                const Hdf5WriteOptions& options) {
    const Volume& h = planes.header();
    validate_dims(h.dims, name_of(file, normalize_dataset(dataset)));
    write_hdf5_with(h, file, dataset, options, [&](hid_t d, hid_t mt, const std::string& what) {
        // Batches of whole planes, one hyperslab write each: the dataset is
        // (Z, Y, X), so planes z0.. are its rows z0.. and lie in the file as the
        // whole write puts them (with deflate, chunks are one plane deep).
        const uint64_t plane = uint64_t(h.dims.x) * uint64_t(h.dims.y) * value_size(h.type);
        const int64_t per = std::clamp<int64_t>(int64_t(kSlabBytes / plane), 1, h.dims.z);
        std::vector<std::byte> buf(std::size_t(per * int64_t(plane)));
        for (int64_t z0 = 0; z0 < h.dims.z; z0 += per) {
            const int64_t n = std::min(per, h.dims.z - z0);
            planes.read(z0, n, buf.data());
            const hsize_t start[3] = {hsize_t(z0), 0, 0};
            const hsize_t count[3] = {hsize_t(n), hsize_t(h.dims.y), hsize_t(h.dims.x)};
            Hid fs(H5Dget_space(d), H5Sclose);
            Hid ms(H5Screate_simple(3, count, nullptr), H5Sclose);  // the selection's shape (fast chunk mapping)
            if (!fs.valid() || !ms.valid() ||
                H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
                H5Dwrite(d, mt, ms.get(), fs.get(), H5P_DEFAULT, buf.data()) < 0)
                throw Error(ErrorCode::IoError, what + ": cannot write planes " + std::to_string(z0) + ".." +
                                                    std::to_string(z0 + n - 1) + ": " + hdf5_error_text());
        }
    });
}

}  // namespace tetlod
