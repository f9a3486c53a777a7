// Creating a volume's dataset in an open HDF5 file. See hdf5_dataset_write.hpp.
#include "hdf5_dataset_write.hpp"

#include <algorithm>
#include <filesystem>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace hdf5_detail {

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

}  // namespace

bool is_hdf5_file(const std::string& path) {
#if H5_VERSION_GE(1, 12, 0)
    return H5Fis_accessible(path.c_str(), H5P_DEFAULT) > 0;
#else
    return H5Fis_hdf5(path.c_str()) > 0;
#endif
}

StagedOutput stage_output(const std::string& file, const std::string& dataset, const OutputPolicy* policy) {
    StagedOutput out;
    out.path = std::make_unique<AtomicPath>(file, "HDF5", /*check_policy=*/false);
    if (policy) policy->check_not_input(file, dataset);
    if (out.path->target_exists()) {
        std::error_code ec;
        std::filesystem::copy_file(out.path->resolved_target(), out.path->temp_path(),
                                   std::filesystem::copy_options::overwrite_existing, ec);
        if (ec) throw Error(ErrorCode::IoError, "cannot copy '" + file + "' to update it: " + ec.message());
        out.update = is_hdf5_file(out.path->temp_path());
        // Not an HDF5 file: the whole file would be replaced.
        if (!out.update && policy) policy->check_replace(file, true);
    }
    return out;
}

Hid open_output_file(const std::string& temp, bool update, hid_t fapl, const std::string& file,
                     const std::string& what) {
    // No time is recorded in any object created here (the root group of a
    // new file, parent groups, the dataset): output bytes depend on the
    // volume only. An updated file's existing groups keep whatever they track.
    const Hid fcpl = untimed_creation_plist(H5P_FILE_CREATE, what);
    Hid f(update ? H5Fopen(temp.c_str(), H5F_ACC_RDWR, fapl) : H5Fcreate(temp.c_str(), H5F_ACC_TRUNC, fcpl.get(), fapl),
          H5Fclose);
    if (!f.valid())
        throw Error(ErrorCode::IoError,
                    std::string("cannot ") + (update ? "open" : "create") + " '" + file + "': " + hdf5_error_text());
    return f;
}

Hid create_volume_dataset(hid_t f, const std::string& file, const std::string& dataset, const Volume& vol,
                          const Hdf5WriteOptions& options, bool update, const OutputPolicy* policy,
                          const std::string& what) {
    if (update) replace_dataset_link(f, file, dataset, what, policy);
    hsize_t shape[3] = {static_cast<hsize_t>(vol.dims.z), static_cast<hsize_t>(vol.dims.y),
                        static_cast<hsize_t>(vol.dims.x)};
    Hid space(H5Screate_simple(3, shape, nullptr), H5Sclose);
    create_parent_groups(f, dataset, what);
    Hid dcpl = untimed_creation_plist(H5P_DATASET_CREATE, what);
    if (options.deflate_level > 0) {
        const std::size_t w = value_size(vol.type);
        hsize_t rows = std::clamp<hsize_t>((std::size_t{1} << 22) / (shape[2] * w), 1, shape[1]);
        hsize_t chunk[3] = {1, rows, shape[2]};
        H5Pset_chunk(dcpl.get(), 3, chunk);
        H5Pset_shuffle(dcpl.get());
        H5Pset_deflate(dcpl.get(), static_cast<unsigned>(options.deflate_level));
    }
    Hid d(H5Dcreate2(f, dataset.c_str(), file_type(vol.type, options.endian), space.get(), H5P_DEFAULT, dcpl.get(),
                     H5P_DEFAULT),
          H5Dclose);
    if (!d.valid()) throw Error(ErrorCode::IoError, what + ": cannot create the dataset: " + hdf5_error_text());
    return d;
}

void write_volume_attributes(hid_t d, const Volume& vol, const std::string& what) {
    const double sp[3] = {vol.spacing[0], vol.spacing[1], vol.spacing[2]};
    const double og[3] = {vol.origin[0], vol.origin[1], vol.origin[2]};
    const long long dm[3] = {vol.dims.x, vol.dims.y, vol.dims.z};
    write_array_attr(d, "spacing", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, sp, what);
    write_string_attr(d, "spacing_order", "xyz", what);
    write_array_attr(d, "origin", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, og, what);
    write_array_attr(d, "dims_xyz", H5T_STD_I64LE, H5T_NATIVE_LLONG, dm, what);
    write_string_attr(d, "axis_order", "zyx", what);
    if (!vol.field_name.empty()) write_string_attr(d, "field_name", vol.field_name, what);
    if (!vol.units.empty()) write_string_attr(d, "units", vol.units, what);
    for (const auto& [k, v] : vol.metadata) {
        if (structural_attributes().count(k)) continue;  // written above from the Volume fields
        if (k.empty() || k == ".") continue;  // not an attribute name: hdf5_unstorable_keys()
        write_string_attr(d, k, v, what);
    }
}

}  // namespace hdf5_detail

using namespace hdf5_detail;

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
    const bool hdf5 = is_hdf5_file(file);
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

}  // namespace tetlod
