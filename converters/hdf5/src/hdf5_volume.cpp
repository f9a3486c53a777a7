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
#include <map>
#include <set>

#include "hdf5_read_guard.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_volume.hpp"
#include "tetlod/core/regular_file.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/output_policy.hpp"

namespace tetlod {

namespace {

constexpr std::size_t kSlabBytes = std::size_t{16} << 20;  // transposing reads go through this much
constexpr hssize_t kMaxAttributeElements = 1 << 16;

// Owns an HDF5 identifier; closes it with the matching function.
class Hid {
public:
    Hid() = default;
    Hid(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
    Hid(Hid&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
    Hid& operator=(Hid&& o) noexcept {
        reset();
        id_ = o.id_;
        close_ = o.close_;
        o.id_ = -1;
        return *this;
    }
    ~Hid() { reset(); }
    void reset() {
        if (id_ >= 0 && close_) close_(id_);
        id_ = -1;
    }
    hid_t get() const { return id_; }
    bool valid() const { return id_ >= 0; }

private:
    hid_t id_ = -1;
    herr_t (*close_)(hid_t) = nullptr;
};

// The library prints its error stack to stderr by default; tetlod reports
// errors itself, so printing is switched off and the innermost message kept.
void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

std::string hdf5_error_text() {
    std::string text;
    H5Ewalk2(
        H5E_DEFAULT, H5E_WALK_UPWARD,
        [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
            auto* s = static_cast<std::string*>(data);
            if (n == 0 && e && e->desc) *s = e->desc;
            return 0;
        },
        &text);
    H5Eclear2(H5E_DEFAULT);
    return text.empty() ? "HDF5 library error" : text;
}

std::string num_text(double v) {
    char buf[64];
    auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
    (void)ec;
    return std::string(buf, p);
}

std::string name_of(const std::string& file, const std::string& dataset) { return "'" + file + ":" + dataset + "'"; }

std::string normalize_dataset(const std::string& d) {
    if (d.empty()) return "/volume";
    return d[0] == '/' ? d : "/" + d;
}

std::vector<std::string> list_datasets(hid_t file, hid_t dapl) {
    struct Visit {
        std::vector<std::string> names;
        hid_t dapl;
    } visit{{}, dapl};
    H5Lvisit(
        file, H5_INDEX_NAME, H5_ITER_INC,
        [](hid_t g, const char* name, const H5L_info_t*, void* data) -> herr_t {
            auto* v = static_cast<Visit*>(data);
            hid_t d = H5Dopen2(g, name, v->dapl);
            if (d >= 0) {
                v->names.push_back(std::string("/") + name);
                H5Dclose(d);
            }
            return v->names.size() >= 20 ? 1 : 0;
        },
        &visit);
    H5Eclear2(H5E_DEFAULT);
    return visit.names;
}

struct Attr {
    std::string text;
    std::vector<double> numbers;  // for numeric attributes
    bool numeric = false;
};

bool read_attribute(hid_t loc, const char* name, Attr& out) {
    Hid a(H5Aopen(loc, name, H5P_DEFAULT), H5Aclose);
    if (!a.valid()) return false;
    Hid ftype(H5Aget_type(a.get()), H5Tclose);
    Hid space(H5Aget_space(a.get()), H5Sclose);
    hssize_t n = H5Sget_simple_extent_npoints(space.get());
    if (n < 0 || n > kMaxAttributeElements) return false;
    H5T_class_t cls = H5Tget_class(ftype.get());
    if (cls == H5T_INTEGER || cls == H5T_FLOAT) {
        const bool is_unsigned = cls == H5T_INTEGER && H5Tget_sign(ftype.get()) == H5T_SGN_NONE;
        std::string text;
        if (cls == H5T_INTEGER) {
            std::vector<long long> v(static_cast<std::size_t>(n));
            hid_t mt = is_unsigned ? H5T_NATIVE_ULLONG : H5T_NATIVE_LLONG;
            if (n > 0 && H5Aread(a.get(), mt, v.data()) < 0) return false;
            for (auto x : v) {
                if (!text.empty()) text += ' ';
                text += is_unsigned ? std::to_string(static_cast<unsigned long long>(x)) : std::to_string(x);
                out.numbers.push_back(is_unsigned ? static_cast<double>(static_cast<unsigned long long>(x))
                                                  : static_cast<double>(x));
            }
        } else {
            std::vector<double> v(static_cast<std::size_t>(n));
            if (n > 0 && H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()) < 0) return false;
            for (double x : v) {
                if (!text.empty()) text += ' ';
                text += num_text(x);
            }
            out.numbers = v;
        }
        out.text = text;
        out.numeric = true;
        return true;
    }
    if (cls == H5T_STRING) {
        if (H5Tis_variable_str(ftype.get()) > 0) {
            Hid mt(H5Tcopy(H5T_C_S1), H5Tclose);
            H5Tset_size(mt.get(), H5T_VARIABLE);
            H5Tset_cset(mt.get(), H5Tget_cset(ftype.get()));
            std::vector<char*> v(static_cast<std::size_t>(n), nullptr);
            if (n > 0 && H5Aread(a.get(), mt.get(), v.data()) < 0) return false;
            for (std::size_t i = 0; i < v.size(); ++i) {
                if (i) out.text += ' ';
                if (v[i]) out.text += v[i];
            }
            if (n > 0) H5Dvlen_reclaim(mt.get(), space.get(), H5P_DEFAULT, v.data());
        } else {
            std::size_t size = H5Tget_size(ftype.get());
            if (size == 0 || size > (1u << 20)) return false;
            Hid mt(H5Tcopy(ftype.get()), H5Tclose);
            std::vector<char> buf(size * static_cast<std::size_t>(n) + 1, '\0');
            if (n > 0 && H5Aread(a.get(), mt.get(), buf.data()) < 0) return false;
            for (hssize_t i = 0; i < n; ++i) {
                const char* s = buf.data() + static_cast<std::size_t>(i) * size;
                if (i) out.text += ' ';
                out.text += std::string(s, strnlen(s, size));
            }
        }
        return true;
    }
    return false;  // compound, enum, reference, ...: not representable as text
}

std::map<std::string, Attr> read_attributes(hid_t obj) {
    std::map<std::string, Attr> out;
    hsize_t idx = 0;
    H5Aiterate2(
        obj, H5_INDEX_NAME, H5_ITER_INC, &idx,
        [](hid_t loc, const char* name, const H5A_info_t*, void* data) -> herr_t {
            auto* m = static_cast<std::map<std::string, Attr>*>(data);
            Attr a;
            if (read_attribute(loc, name, a)) (*m)[name] = std::move(a);
            H5Eclear2(H5E_DEFAULT);
            return 0;
        },
        &out);
    H5Eclear2(H5E_DEFAULT);
    return out;
}

std::optional<ValueType> value_type_from(hid_t t, std::string& why) {
    H5T_class_t cls = H5Tget_class(t);
    std::size_t size = H5Tget_size(t);
    if (cls == H5T_INTEGER) {
        bool sgn = H5Tget_sign(t) != H5T_SGN_NONE;
        switch (size) {
            case 1: return sgn ? ValueType::I8 : ValueType::U8;
            case 2: return sgn ? ValueType::I16 : ValueType::U16;
            case 4: return sgn ? ValueType::I32 : ValueType::U32;
            default: why = std::to_string(size * 8) + "-bit integers (tetlod volumes hold at most 32-bit integers)";
        }
        return std::nullopt;
    }
    if (cls == H5T_FLOAT) {
        if (size == 4) return ValueType::F32;
        if (size == 8) return ValueType::F64;
        why = std::to_string(size * 8) + "-bit floats";
        return std::nullopt;
    }
    why = "non-numeric data (class " + std::to_string(static_cast<int>(cls)) + ")";
    return std::nullopt;
}

hid_t native_type(ValueType t) {
    switch (t) {
        case ValueType::U8: return H5T_NATIVE_UINT8;
        case ValueType::I8: return H5T_NATIVE_INT8;
        case ValueType::U16: return H5T_NATIVE_UINT16;
        case ValueType::I16: return H5T_NATIVE_INT16;
        case ValueType::U32: return H5T_NATIVE_UINT32;
        case ValueType::I32: return H5T_NATIVE_INT32;
        case ValueType::F32: return H5T_NATIVE_FLOAT;
        case ValueType::F64: return H5T_NATIVE_DOUBLE;
    }
    return H5T_NATIVE_UINT8;
}

hid_t file_type(ValueType t, Endian e) {
    const bool be = e == Endian::Big;
    switch (t) {
        case ValueType::U8: return be ? H5T_STD_U8BE : H5T_STD_U8LE;
        case ValueType::I8: return be ? H5T_STD_I8BE : H5T_STD_I8LE;
        case ValueType::U16: return be ? H5T_STD_U16BE : H5T_STD_U16LE;
        case ValueType::I16: return be ? H5T_STD_I16BE : H5T_STD_I16LE;
        case ValueType::U32: return be ? H5T_STD_U32BE : H5T_STD_U32LE;
        case ValueType::I32: return be ? H5T_STD_I32BE : H5T_STD_I32LE;
        case ValueType::F32: return be ? H5T_IEEE_F32BE : H5T_IEEE_F32LE;
        case ValueType::F64: return be ? H5T_IEEE_F64BE : H5T_IEEE_F64LE;
    }
    return H5T_STD_U8LE;
}

// Attributes the reader turns into Volume fields; the writer owns these names.
const std::set<std::string>& structural_attributes() {
    static const std::set<std::string> s = {"spacing", "spacing_order", "origin",  "axis_order",
                                            "dims_xyz", "field_name",   "units"};
    return s;
}

}  // namespace

namespace {

// The read itself, in whichever process read_hdf5 chose.
Volume read_hdf5_here(const std::string& file, const std::string& dataset_in, const VolumeReadOptions& options,
                      uint64_t file_size) {
    silence_hdf5();
    std::error_code ec;
    if (H5Fis_hdf5(file.c_str()) <= 0) {
        H5Eclear2(H5E_DEFAULT);
        throw Error(ErrorCode::BadMagic, "'" + file + "' is not an HDF5 file");
    }
    Hid f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) throw Error(ErrorCode::IoError, "cannot open '" + file + "': " + hdf5_error_text());
    Hid dapl(hdf5_guard::make_safe_dataset_access(file), H5Pclose);
    std::string dataset = normalize_dataset(dataset_in);
    if (dataset_in.empty()) {
        // No path given: the file's only dataset.
        auto all = list_datasets(f.get(), dapl.get());
        if (all.size() == 1) {
            dataset = all[0];
        } else if (all.size() > 1) {
            std::string list;
            for (const auto& n : all) list += (list.empty() ? "" : ", ") + n;
            throw Error(ErrorCode::InvalidArgument, "'" + file + "' holds several datasets (" + list +
                                                        "); name one as " + file + ":/path");
        }
    }
    const std::string what = name_of(file, dataset);

    // Walk the path one link at a time: H5Lexists on a path whose parent is
    // missing is itself an error.
    bool exists = true;
    for (std::size_t p = 1; p <= dataset.size() && exists; ++p) {
        if (p == dataset.size() || dataset[p] == '/') {
            std::string prefix = dataset.substr(0, p);
            if (prefix == "/") continue;
            exists = H5Lexists(f.get(), prefix.c_str(), dapl.get()) > 0;
            H5L_info_t link{};
            if (exists && H5Lget_info(f.get(), prefix.c_str(), &link, dapl.get()) >= 0 && link.type != H5L_TYPE_HARD &&
                link.type != H5L_TYPE_SOFT)
                throw Error(ErrorCode::UnsupportedFeature,
                            "'" + file + "': '" + prefix +
                                "' is an external (or user-defined) link to another file; tetlod reads only data "
                                "stored in the file itself");
        }
    }
    H5Eclear2(H5E_DEFAULT);
    Hid d;
    if (exists) d = Hid(H5Dopen2(f.get(), dataset.c_str(), dapl.get()), H5Dclose);
    if (!d.valid()) {
        H5Eclear2(H5E_DEFAULT);
        std::string list;
        for (const auto& n : list_datasets(f.get(), dapl.get())) list += (list.empty() ? "" : ", ") + n;
        throw Error(ErrorCode::NotFound, "'" + file + "' has no dataset '" + dataset + "' (datasets: " +
                                             (list.empty() ? "none" : list) + ")");
    }

    Hid ftype(H5Dget_type(d.get()), H5Tclose);
    std::string why;
    auto type = value_type_from(ftype.get(), why);
    if (!type) throw Error(ErrorCode::UnsupportedFeature, what + ": dataset holds " + why);

    Hid space(H5Dget_space(d.get()), H5Sclose);
    int rank = H5Sget_simple_extent_ndims(space.get());
    if (rank < 1 || rank > 3)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": dataset rank " + std::to_string(rank) + " (tetlod reads 1 to 3 axes)");
    hsize_t shape[3] = {1, 1, 1};
    H5Sget_simple_extent_dims(space.get(), shape, nullptr);

    auto attrs = read_attributes(d.get());
    auto attr_text = [&](const char* k) -> std::string {
        auto it = attrs.find(k);
        return it == attrs.end() ? std::string() : it->second.text;
    };

    std::string order = options.axis_order;
    if (order.empty()) order = attr_text("axis_order");
    if (order.empty()) order = "zyx";
    if (order != "zyx" && order != "xyz")
        throw Error(ErrorCode::InvalidArgument,
                    what + ": axis order '" + order + "' (expected zyx, the C-order default, or xyz)");
    const bool xyz = order == "xyz";
    // Dataset axis a (0 = slowest in C order) -> volume axis.
    int64_t v[3] = {1, 1, 1};
    for (int a = 0; a < rank; ++a) v[xyz ? a : rank - 1 - a] = static_cast<int64_t>(shape[a]);
    Dims dims{v[0], v[1], v[2]};
    validate_dims(dims, what);

    if (auto it = attrs.find("dims_xyz"); it != attrs.end() && it->second.numeric) {
        const auto& n = it->second.numbers;
        bool same = n.size() == 3 || static_cast<int>(n.size()) == rank;
        for (std::size_t a = 0; same && a < n.size(); ++a) same = n[a] == static_cast<double>(dims[static_cast<int>(a)]);
        if (!same)
            throw Error(ErrorCode::SizeMismatch, what + ": attribute dims_xyz (" + it->second.text +
                                                     ") does not match the dataset extent " +
                                                     std::to_string(dims.x) + " " + std::to_string(dims.y) + " " +
                                                     std::to_string(dims.z) + " read as " + order);
    }

    // Before allocating: a contiguous dataset must lie inside the file.
    Hid dcpl(H5Dget_create_plist(d.get()), H5Pclose);
    hdf5_guard::check_dataset_claims(d.get(), dcpl.get(),
                                     static_cast<uint64_t>(dims.count()) * H5Tget_size(ftype.get()),
                                     H5Tget_size(ftype.get()), file, file_size, what);
    if (H5Pget_layout(dcpl.get()) == H5D_CONTIGUOUS && H5Pget_external_count(dcpl.get()) == 0) {
        haddr_t off = H5Dget_offset(d.get());
        uint64_t stored_bytes = static_cast<uint64_t>(dims.count()) * H5Tget_size(ftype.get());
        uint64_t fsize = file_size;
        if (off != HADDR_UNDEF && (off > fsize || fsize - off < stored_bytes))
            throw Error(ErrorCode::Truncated, what + ": file is truncated: the dataset needs " +
                                                  std::to_string(stored_bytes) + " bytes at offset " +
                                                  std::to_string(off) + ", the file has " + std::to_string(fsize));
        H5Eclear2(H5E_DEFAULT);
    }

    Volume vol = Volume::allocate(dims, *type);
    const hid_t mt = native_type(*type);
    if (!xyz) {
        // Same element order as the volume: one read straight into it. The library
        // converts byte order through its own bounded buffer (1 MiB by default)
        // and decodes chunks one at a time, so no extra copy of the volume exists.
        if (H5Dread(d.get(), mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, vol.data.data()) < 0)
            throw Error(ErrorCode::CorruptData, what + ": cannot read the dataset: " + hdf5_error_text());
    } else {
        // Dataset [x][y][z]: read slabs of x planes, scatter them into x-fastest order.
        const std::size_t w = value_size(*type);
        const uint64_t plane = static_cast<uint64_t>(dims.y) * static_cast<uint64_t>(dims.z);
        const int64_t per = std::max<int64_t>(1, static_cast<int64_t>(kSlabBytes / (plane * w)));
        std::vector<std::byte> slab(static_cast<std::size_t>(std::min<int64_t>(per, dims.x) * plane * w));
        for (int64_t x0 = 0; x0 < dims.x; x0 += per) {
            int64_t nx = std::min<int64_t>(per, dims.x - x0);
            hsize_t start[3] = {static_cast<hsize_t>(x0), 0, 0};
            hsize_t count[3] = {static_cast<hsize_t>(nx), rank > 1 ? static_cast<hsize_t>(dims.y) : 1,
                                rank > 2 ? static_cast<hsize_t>(dims.z) : 1};
            Hid fs(H5Dget_space(d.get()), H5Sclose);
            H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
            hsize_t mcount = static_cast<hsize_t>(nx) * plane;
            Hid ms(H5Screate_simple(1, &mcount, nullptr), H5Sclose);
            if (H5Dread(d.get(), mt, ms.get(), fs.get(), H5P_DEFAULT, slab.data()) < 0)
                throw Error(ErrorCode::CorruptData, what + ": cannot read the dataset: " + hdf5_error_text());
            for (int64_t i = 0; i < nx; ++i)
                for (int64_t j = 0; j < dims.y; ++j)
                    for (int64_t k = 0; k < dims.z; ++k) {
                        const std::byte* src = slab.data() + ((i * dims.y + j) * dims.z + k) * w;
                        std::memcpy(vol.data.data() + dims.index(x0 + i, j, k) * w, src, w);
                    }
        }
    }

    // Geometry from attributes.
    Vec3 spacing{1, 1, 1}, origin{0, 0, 0};
    auto three = [&](const char* k) -> const std::vector<double>* {
        auto it = attrs.find(k);
        if (it == attrs.end() || !it->second.numeric || it->second.numbers.size() != 3) return nullptr;
        return &it->second.numbers;
    };
    if (auto* s = three("spacing")) {
        bool zyx_order = attr_text("spacing_order") == "zyx";
        for (int a = 0; a < 3; ++a) spacing[a] = (*s)[zyx_order ? 2 - a : a];
    } else if (auto* s = three("element_size_um")) {
        for (int a = 0; a < 3; ++a) spacing[a] = (*s)[xyz ? a : 2 - a];
    }
    for (double& s : spacing)
        if (!(std::isfinite(s) && s > 0))
            throw Error(ErrorCode::CorruptData, what + ": spacing attribute holds a value that is not positive");
    if (auto* o = three("origin"))
        for (int a = 0; a < 3; ++a) origin[a] = (*o)[a];
    vol.spacing = options.spacing.value_or(spacing);
    vol.origin = options.origin.value_or(origin);
    if (auto t = attr_text("field_name"); !t.empty()) vol.field_name = t;
    else vol.field_name = dataset.substr(dataset.rfind('/') + 1);
    vol.units = attr_text("units");
    for (const auto& [k, a] : attrs)
        if (!structural_attributes().count(k)) vol.metadata[k] = a.text;
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

void write_hdf5(const Volume& vol, const std::string& file, const std::string& dataset_in,
                const Hdf5WriteOptions& options) {
    const std::string dataset = normalize_dataset(dataset_in);
    const std::string what = name_of(file, dataset);
    validate_dims(vol.dims, what);
    if (vol.data.size() != static_cast<std::size_t>(vol.dims.count()) * value_size(vol.type))
        throw Error(ErrorCode::InvalidArgument, what + ": volume data size does not match its dims");
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
        Hid f(update ? H5Fopen(temp.c_str(), H5F_ACC_RDWR, H5P_DEFAULT)
                     : H5Fcreate(temp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
              H5Fclose);
        if (!f.valid())
            throw Error(ErrorCode::IoError,
                        std::string("cannot ") + (update ? "open" : "create") + " '" + file + "': " + hdf5_error_text());
        if (update) replace_dataset_link(f.get(), file, dataset, what, policy);
        hsize_t shape[3] = {static_cast<hsize_t>(vol.dims.z), static_cast<hsize_t>(vol.dims.y),
                            static_cast<hsize_t>(vol.dims.x)};
        Hid space(H5Screate_simple(3, shape, nullptr), H5Sclose);
        Hid lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
        H5Pset_create_intermediate_group(lcpl.get(), 1);
        Hid dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
        if (options.deflate_level > 0) {
            const std::size_t w = value_size(vol.type);
            hsize_t rows = std::clamp<hsize_t>((std::size_t{1} << 22) / (shape[2] * w), 1, shape[1]);
            hsize_t chunk[3] = {1, rows, shape[2]};
            H5Pset_chunk(dcpl.get(), 3, chunk);
            H5Pset_shuffle(dcpl.get());
            H5Pset_deflate(dcpl.get(), static_cast<unsigned>(options.deflate_level));
        }
        Hid d(H5Dcreate2(f.get(), dataset.c_str(), file_type(vol.type, options.endian), space.get(), lcpl.get(),
                         dcpl.get(), H5P_DEFAULT),
              H5Dclose);
        if (!d.valid()) throw Error(ErrorCode::IoError, what + ": cannot create the dataset: " + hdf5_error_text());
        if (H5Dwrite(d.get(), native_type(vol.type), H5S_ALL, H5S_ALL, H5P_DEFAULT, vol.data.data()) < 0)
            throw Error(ErrorCode::IoError, what + ": cannot write the dataset: " + hdf5_error_text());
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

}  // namespace tetlod
