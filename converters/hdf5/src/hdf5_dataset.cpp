// Opening an HDF5 dataset and reading its planes by hyperslab. See hdf5_dataset.hpp.
#include "hdf5_dataset.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>

#include "hdf5_read_guard.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::hdf5_detail {

namespace {

constexpr hssize_t kMaxAttributeElements = 1 << 16;

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

bool is_prime(uint64_t n) {
    if (n < 2) return false;
    for (uint64_t d = 2; d * d <= n; ++d)
        if (n % d == 0) return false;
    return true;
}

// The chunk cache that holds every chunk of two layers (a read crossing from
// one layer of chunks to the next needs both): reading plane by plane then
// decodes each chunk once (the default 1 MiB cache would decode a chunk again
// for every plane it spans). Slots: a prime, ~100 per chunk, as the library's
// documentation advises (its hash evicts a chunk on any collision).
void set_plane_cache(Hdf5Source& src, hid_t dcpl, hid_t access) {
    if (H5Pget_layout(dcpl) != H5D_CHUNKED) return;
    hsize_t chunk[H5S_MAX_RANK] = {0};
    if (H5Pget_chunk(dcpl, H5S_MAX_RANK, chunk) != src.rank) return;
    const int z_axis = src.rank < 3 ? -1 : src.xyz ? 2 : 0;  // rank < 3: one plane, the whole dataset
    uint64_t chunks = 1, chunk_bytes = value_size(src.header.type);
    for (int a = 0; a < src.rank; ++a) {
        chunk_bytes *= chunk[a];  // bounded by check_dataset_claims
        if (a != z_axis) chunks *= (src.shape[a] + chunk[a] - 1) / chunk[a];
    }
    chunks *= 2;
    src.cache_bytes = std::min<uint64_t>(kMaxPlaneCacheBytes, chunks * chunk_bytes);
    uint64_t slots = std::clamp<uint64_t>(chunks * 100, 521, uint64_t{1} << 24);
    while (!is_prime(slots)) ++slots;
    H5Pset_chunk_cache(access, std::size_t(slots), std::size_t(src.cache_bytes), 1.0);
}

}  // namespace

Hdf5Source open_hdf5_source(const std::string& file, const std::string& dataset_in, const VolumeReadOptions& options,
                            uint64_t file_size, bool for_planes, hid_t fapl) {
    silence_hdf5();
    if (H5Fis_hdf5(file.c_str()) <= 0) {
        H5Eclear2(H5E_DEFAULT);
        throw Error(ErrorCode::BadMagic, "'" + file + "' is not an HDF5 file");
    }
    Hdf5Source src;
    src.file = Hid(H5Fopen(file.c_str(), H5F_ACC_RDONLY, fapl), H5Fclose);
    const Hid& f = src.file;
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
    src.header.spacing = options.spacing.value_or(spacing);
    src.header.origin = options.origin.value_or(origin);
    if (auto t = attr_text("field_name"); !t.empty()) src.header.field_name = t;
    else src.header.field_name = dataset.substr(dataset.rfind('/') + 1);
    src.header.units = attr_text("units");
    for (const auto& [k, a] : attrs)
        if (!structural_attributes().count(k)) src.header.metadata[k] = a.text;
    src.what = what;
    src.header.dims = dims;
    src.header.type = *type;
    src.rank = rank;
    src.xyz = xyz;
    std::copy(shape, shape + 3, src.shape);
    if (for_planes) {
        // Reopened with the cache: a dataset's cache is fixed when it is first
        // opened, and a second handle on an open dataset shares the first's.
        set_plane_cache(src, dcpl.get(), dapl.get());
        if (src.cache_bytes > 0) {
            d.reset();
            d = Hid(H5Dopen2(f.get(), dataset.c_str(), dapl.get()), H5Dclose);
            if (!d.valid()) throw Error(ErrorCode::CorruptData, what + ": cannot reopen the dataset: " + hdf5_error_text());
        }
    }
    src.dataset = std::move(d);
    return src;
}

void read_hdf5_planes(const Hdf5Source& src, int64_t z0, int64_t count, std::byte* dst,
                      std::vector<std::byte>& scratch, hid_t dxpl) {
    const Dims dims = src.header.dims;
    if (count == 0) {
        // An empty selection: a collective read needs every rank's call.
        const hsize_t one = 1;
        Hid fs(H5Dget_space(src.dataset.get()), H5Sclose);
        Hid ms(H5Screate_simple(1, &one, nullptr), H5Sclose);
        std::byte unused[8];
        if (!fs.valid() || !ms.valid() || H5Sselect_none(fs.get()) < 0 || H5Sselect_none(ms.get()) < 0 ||
            H5Dread(src.dataset.get(), native_type(src.header.type), ms.get(), fs.get(), dxpl, unused) < 0)
            throw Error(ErrorCode::CorruptData, src.what + ": cannot join the collective read: " + hdf5_error_text());
        return;
    }
    const std::size_t w = value_size(src.header.type);
    hsize_t start[3] = {0, 0, 0}, size[3] = {src.shape[0], src.shape[1], src.shape[2]};
    if (src.rank == 3) {  // rank < 3: dims.z is 1, the plane is the whole dataset
        const int z_axis = src.xyz ? 2 : 0;
        start[z_axis] = hsize_t(z0);
        size[z_axis] = hsize_t(count);
    }
    const hsize_t points = hsize_t(dims.x) * hsize_t(dims.y) * hsize_t(count);
    Hid fs(H5Dget_space(src.dataset.get()), H5Sclose);
    // The memory space has the selection's shape: with a shape of its own (one
    // axis, say) the library maps chunks to memory element by element, ten
    // times slower on chunked datasets.
    Hid ms(H5Screate_simple(src.rank, size, nullptr), H5Sclose);
    if (!fs.valid() || !ms.valid() || H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start, nullptr, size, nullptr) < 0)
        throw Error(ErrorCode::CorruptData, src.what + ": cannot select planes: " + hdf5_error_text());
    const hid_t mt = native_type(src.header.type);
    const bool transpose = src.xyz && src.rank > 1;
    std::byte* out = dst;
    if (transpose) {
        scratch.resize(std::size_t(points) * w);
        out = scratch.data();
    }
    if (H5Dread(src.dataset.get(), mt, ms.get(), fs.get(), dxpl, out) < 0)
        throw Error(ErrorCode::CorruptData, src.what + ": cannot read the dataset: " + hdf5_error_text());
    if (!transpose) return;
    // The slab is [x][y][k]; the planes are [k][y][x].
    const int64_t nx = dims.x, ny = dims.y, nk = count;
    for (int64_t x = 0; x < nx; ++x)
        for (int64_t y = 0; y < ny; ++y) {
            const std::byte* from = scratch.data() + std::size_t((x * ny + y) * nk) * w;
            for (int64_t k = 0; k < nk; ++k)
                std::memcpy(dst + std::size_t((k * ny + y) * nx + x) * w, from + std::size_t(k) * w, w);
        }
}

}  // namespace tetlod::hdf5_detail
