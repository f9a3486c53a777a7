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

void write_string_attr(hid_t obj, const std::string& name, const std::string& value, const std::string& what) {
    Hid t(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(t.get(), H5T_VARIABLE);
    H5Tset_cset(t.get(), H5T_CSET_UTF8);
    Hid s(H5Screate(H5S_SCALAR), H5Sclose);
    Hid a(H5Acreate2(obj, name.c_str(), t.get(), s.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    const char* p = value.c_str();
    if (!a.valid() || H5Awrite(a.get(), t.get(), &p) < 0)
        throw Error(ErrorCode::IoError, what + ": cannot write attribute '" + name + "': " + hdf5_error_text());
}

template <class T>
void write_array_attr(hid_t obj, const char* name, hid_t ftype, hid_t mtype, const T (&v)[3], const std::string& what) {
    hsize_t n = 3;
    Hid s(H5Screate_simple(1, &n, nullptr), H5Sclose);
    Hid a(H5Acreate2(obj, name, ftype, s.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!a.valid() || H5Awrite(a.get(), mtype, v) < 0)
        throw Error(ErrorCode::IoError, what + ": cannot write attribute '" + name + "': " + hdf5_error_text());
}

// Makes room for `dataset` in an existing file: nothing to do when no link has
// that name; an existing dataset is unlinked when the policy allows replacing it;
// a group (or anything else) is never removed (it may hold many datasets).
void replace_dataset_link(hid_t file, const std::string& file_name, const std::string& dataset, const std::string& what,
                          const OutputPolicy* policy) {
    std::string prefix;
    std::size_t pos = 0;
    while (pos < dataset.size()) {  // every link on the path must exist (H5Lexists needs its parents)
        const std::size_t next = dataset.find('/', pos + 1);
        prefix = dataset.substr(0, next);
        if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return;
        if (next == std::string::npos) break;
        pos = next;
    }
    Hid obj(H5Oopen(file, dataset.c_str(), H5P_DEFAULT), H5Oclose);
    if (!obj.valid() || H5Iget_type(obj.get()) != H5I_DATASET)
        throw Error(ErrorCode::InvalidArgument, what + " exists and is not a dataset: refusing to replace it");
    obj.reset();
    if (policy) policy->check_replace(file_name + ":" + dataset, true);
    if (H5Ldelete(file, dataset.c_str(), H5P_DEFAULT) < 0)
        throw Error(ErrorCode::IoError, what + ": cannot remove the old dataset: " + hdf5_error_text());
}

}  // namespace

std::vector<std::string> hdf5_unstorable_keys(const Volume& vol) {
    std::vector<std::string> out;
    for (const auto& [k, v] : vol.metadata)
        if (k.empty() || k == "." || structural_attributes().count(k)) out.push_back(k);
    return out;
}

void check_hdf5_output(const std::string& file, const std::string& dataset_in) {
    const std::string dataset = normalize_dataset(dataset_in);
    const std::string what = name_of(file, dataset);
    OutputPolicy* policy = active_output_policy();
    if (policy) policy->check_not_input(file, dataset);
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) return;  // a new file: nothing to lose
    silence_hdf5();
#if H5_VERSION_GE(1, 12, 0)
    const bool hdf5 = H5Fis_accessible(file.c_str(), H5P_DEFAULT) > 0;
#else
    const bool hdf5 = H5Fis_hdf5(file.c_str()) > 0;
#endif
    if (!hdf5) {
        if (policy) policy->check_replace(file, true);  // the whole file would be replaced
        return;
    }
    Hid f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) return;  // the writer reports why it cannot open it
    std::size_t pos = 0;
    while (pos < dataset.size()) {  // every link on the path must exist (H5Lexists needs its parents)
        const std::size_t next = dataset.find('/', pos + 1);
        if (H5Lexists(f.get(), dataset.substr(0, next).c_str(), H5P_DEFAULT) <= 0) return;
        if (next == std::string::npos) break;
        pos = next;
    }
    Hid obj(H5Oopen(f.get(), dataset.c_str(), H5P_DEFAULT), H5Oclose);
    if (!obj.valid() || H5Iget_type(obj.get()) != H5I_DATASET)
        throw Error(ErrorCode::InvalidArgument, what + " exists and is not a dataset: refusing to replace it");
    if (policy) policy->check_replace(file + ":" + dataset, true);
}

namespace {

// A creation property list of class `cls` (file, group or dataset) without the
// access, modification, change and birth times libhdf5 otherwise stamps into
// the object's header: the same volume written twice gives the same bytes.
Hid untimed_creation_plist(hid_t cls, const std::string& what) {
    Hid p(H5Pcreate(cls), H5Pclose);
    if (!p.valid() || H5Pset_obj_track_times(p.get(), 0) < 0)
        throw Error(ErrorCode::IoError, what + ": cannot set up an HDF5 property list: " + hdf5_error_text());
    return p;
}

// Creates the groups on the way to `dataset` that do not exist yet, untimed (the
// library's intermediate group creation takes no group creation property list).
// A path through something that is not a group is left to H5Dcreate2 to refuse.
void create_parent_groups(hid_t file, const std::string& dataset, const std::string& what) {
    const Hid gcpl = untimed_creation_plist(H5P_GROUP_CREATE, what);
    std::string prefix;
    for (std::size_t pos = 1;;) {
        const std::size_t next = dataset.find('/', pos);
        if (next == std::string::npos) return;  // the last name is the dataset's
        const std::string name = dataset.substr(pos, next - pos);
        pos = next + 1;
        if (name.empty() || name == ".") continue;  // "a//b" and "a/./b" name "a/b", as in HDF5
        prefix += "/" + name;
        const htri_t exists = H5Lexists(file, prefix.c_str(), H5P_DEFAULT);
        if (exists > 0) continue;
        if (exists < 0) return;
        Hid g(H5Gcreate2(file, prefix.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
        if (!g.valid())
            throw Error(ErrorCode::IoError,
                        what + ": cannot create the group '" + prefix + "': " + hdf5_error_text());
    }
}

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

    // The library writes the file itself: atomicity comes from a temporary copy
    // beside the target (symlinks followed) renamed over it at the end. An existing
    // HDF5 file is copied first so its other datasets and attributes survive;
    // only `dataset` is added or (with the policy's force) replaced.
    AtomicPath out(file, "HDF5", /*check_policy=*/false);
    const std::string& temp = out.temp_path();
    OutputPolicy* policy = active_output_policy();
    if (policy) policy->check_not_input(file, dataset);
    bool update = false;  // open the copy of an existing HDF5 file, else create a new file
    if (out.target_exists()) {
        std::error_code ec;
        std::filesystem::copy_file(out.resolved_target(), temp, std::filesystem::copy_options::overwrite_existing,
                                   ec);
        if (ec) throw Error(ErrorCode::IoError, "cannot copy '" + file + "' to update it: " + ec.message());
#if H5_VERSION_GE(1, 12, 0)
        update = H5Fis_accessible(temp.c_str(), H5P_DEFAULT) > 0;
#else
        update = H5Fis_hdf5(temp.c_str()) > 0;
#endif
        // Not an HDF5 file: the whole file would be replaced.
        if (!update && policy) policy->check_replace(file, true);
    }

    {
        // No time is recorded in any object created here (the root group of a
        // new file, parent groups, the dataset): output bytes depend on the
        // volume only. An updated file's existing groups keep whatever they track.
        const Hid fcpl = untimed_creation_plist(H5P_FILE_CREATE, what);
        Hid f(update ? H5Fopen(temp.c_str(), H5F_ACC_RDWR, H5P_DEFAULT)
                     : H5Fcreate(temp.c_str(), H5F_ACC_TRUNC, fcpl.get(), H5P_DEFAULT),
              H5Fclose);
        if (!f.valid())
            throw Error(ErrorCode::IoError,
                        std::string("cannot ") + (update ? "open" : "create") + " '" + file + "': " + hdf5_error_text());
        if (update) replace_dataset_link(f.get(), file, dataset, what, policy);
        hsize_t shape[3] = {static_cast<hsize_t>(vol.dims.z), static_cast<hsize_t>(vol.dims.y),
                            static_cast<hsize_t>(vol.dims.x)};
        Hid space(H5Screate_simple(3, shape, nullptr), H5Sclose);
        create_parent_groups(f.get(), dataset, what);
        Hid dcpl = untimed_creation_plist(H5P_DATASET_CREATE, what);
        if (options.deflate_level > 0) {
            const std::size_t w = value_size(vol.type);
            hsize_t rows = std::clamp<hsize_t>((std::size_t{1} << 22) / (shape[2] * w), 1, shape[1]);
            hsize_t chunk[3] = {1, rows, shape[2]};
            H5Pset_chunk(dcpl.get(), 3, chunk);
            H5Pset_shuffle(dcpl.get());
            H5Pset_deflate(dcpl.get(), static_cast<unsigned>(options.deflate_level));
        }
        Hid d(H5Dcreate2(f.get(), dataset.c_str(), file_type(vol.type, options.endian), space.get(), H5P_DEFAULT,
                         dcpl.get(), H5P_DEFAULT),
              H5Dclose);
        if (!d.valid()) throw Error(ErrorCode::IoError, what + ": cannot create the dataset: " + hdf5_error_text());
        fill(d.get(), native_type(vol.type), what);
        const double sp[3] = {vol.spacing[0], vol.spacing[1], vol.spacing[2]};
        const double og[3] = {vol.origin[0], vol.origin[1], vol.origin[2]};
        const long long dm[3] = {vol.dims.x, vol.dims.y, vol.dims.z};
        write_array_attr(d.get(), "spacing", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, sp, what);
        write_string_attr(d.get(), "spacing_order", "xyz", what);
        write_array_attr(d.get(), "origin", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, og, what);
        write_array_attr(d.get(), "dims_xyz", H5T_STD_I64LE, H5T_NATIVE_LLONG, dm, what);
        write_string_attr(d.get(), "axis_order", "zyx", what);
        if (!vol.field_name.empty()) write_string_attr(d.get(), "field_name", vol.field_name, what);
        if (!vol.units.empty()) write_string_attr(d.get(), "units", vol.units, what);
        for (const auto& [k, v] : vol.metadata) {
            if (structural_attributes().count(k)) continue;  // written above from the Volume fields
            if (k.empty() || k == ".") continue;  // not an attribute name: hdf5_unstorable_keys()
            write_string_attr(d.get(), k, v, what);
        }
        if (H5Fflush(f.get(), H5F_SCOPE_GLOBAL) < 0)
            throw Error(ErrorCode::IoError, "cannot flush '" + file + "': " + hdf5_error_text());
    }
    out.commit();
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
