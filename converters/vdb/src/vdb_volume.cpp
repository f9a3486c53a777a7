// OpenVDB volume reader and writer (OpenVDB 10 library API). The only file in
// tetlod that includes openvdb.h. See tetlod/converters/vdb.hpp for the rules.
#include "tetlod/converters/vdb.hpp"

#include <openvdb/openvdb.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fcntl.h>
#include <optional>
#include <set>
#include <sys/stat.h>
#include <unistd.h>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

// OpenVDB's own bookkeeping metadata: statistics written with the file and
// per-grid flags the library interprets. None of it describes the field.
bool is_internal_meta(const std::string& k) {
    return k.rfind("file_", 0) == 0 || k == "name" || k == "is_saved_as_half_float" || k == "is_local_space" ||
           k == "vector_type";
}

// Names the reader turns into Volume fields and the writer owns.
bool is_structural_meta(const std::string& k) {
    return k == "dims_xyz" || k == "tetlod_value_type" || k == "units";
}

std::string short_type(const openvdb::GridBase& g) { return g.valueType(); }

bool is_scalar_type(const std::string& t) {
    return t == "float" || t == "double" || t == "int32" || t == "int64" || t == "bool";
}

// Integers in a metadata value's text ("[64, 64, 93]", "64 64 93").
std::vector<int64_t> integers_in(const std::string& s) {
    std::vector<int64_t> out;
    std::size_t i = 0;
    while (i < s.size()) {
        if (std::isdigit(static_cast<unsigned char>(s[i])) ||
            (s[i] == '-' && i + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[i + 1])))) {
            std::size_t b = i++;
            while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
            if (i < s.size() && (s[i] == '.' || s[i] == 'e' || s[i] == 'E')) return {};  // not integers
            out.push_back(std::stoll(s.substr(b, i - b)));
        } else {
            ++i;
        }
    }
    return out;
}

openvdb::io::File open_file(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw Error(ErrorCode::IoError, "cannot open '" + path + "': no such file");
    openvdb::initialize();
    openvdb::io::File f(path);
    try {
        f.open(false);
    } catch (const std::exception& e) {
        throw Error(ErrorCode::BadMagic, "'" + path + "' is not a readable OpenVDB file: " + e.what());
    }
    return f;
}

struct Extent {
    openvdb::Coord min;
    Dims dims;
};

template <class GridT>
void fill_dense(const GridT& grid, const Extent& ext, Volume& vol, const std::string& what) {
    using V = typename GridT::ValueType;
    const V bg = grid.background();
    auto store = [&](int64_t idx, const V& v) {
        if constexpr (std::is_same_v<V, bool>) {
            vol.as<uint8_t>()[idx] = v ? 1 : 0;
        } else if constexpr (std::is_same_v<V, int64_t>) {
            // Staged as double, narrowed to a 32-bit type afterwards (read_vdb).
            if (v < -(int64_t{1} << 53) || v > (int64_t{1} << 53))
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": Int64 grid value " + std::to_string(v) + " does not fit a 32-bit integer");
            vol.as<double>()[idx] = static_cast<double>(v);
        } else {
            vol.as<V>()[idx] = v;
        }
    };
    const int64_t n = vol.count();
    for (int64_t i = 0; i < n; ++i) store(i, bg);
    const openvdb::CoordBBox box(ext.min, ext.min + openvdb::Coord(static_cast<int32_t>(ext.dims.x - 1),
                                                                   static_cast<int32_t>(ext.dims.y - 1),
                                                                   static_cast<int32_t>(ext.dims.z - 1)));
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        openvdb::CoordBBox b;
        it.getBoundingBox(b);  // one voxel, or a whole active tile
        b.intersect(box);
        if (b.empty()) continue;
        const V v = *it;
        for (int32_t z = b.min().z(); z <= b.max().z(); ++z)
            for (int32_t y = b.min().y(); y <= b.max().y(); ++y)
                for (int32_t x = b.min().x(); x <= b.max().x(); ++x)
                    store(ext.dims.index(x - ext.min.x(), y - ext.min.y(), z - ext.min.z()), v);
    }
}

// Converts to `target` when every value survives the round trip exactly.
bool try_narrow(Volume& vol, ValueType target) {
    if (target == vol.type) return true;
    Volume out;
    out.dims = vol.dims;
    out.type = target;
    out.data.resize(static_cast<std::size_t>(vol.count()) * value_size(target));
    const int64_t n = vol.count();
    bool ok = dispatch_value_type(target, [&](auto t) {
        using T = decltype(t);
        T* dst = out.as<T>();
        for (int64_t i = 0; i < n; ++i) {
            double v = vol.value(i);
            if (!std::isfinite(v) && !std::is_floating_point_v<T>) return false;
            if constexpr (!std::is_floating_point_v<T>) {
                if (v < static_cast<double>(std::numeric_limits<T>::min()) ||
                    v > static_cast<double>(std::numeric_limits<T>::max()))
                    return false;
            }
            T c = static_cast<T>(v);
            if (static_cast<double>(c) != v && !(std::isnan(v) && std::isnan(static_cast<double>(c)))) return false;
            dst[i] = c;
        }
        return true;
    });
    if (!ok) return false;
    vol.type = target;
    vol.data = std::move(out.data);
    return true;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> list_vdb_grids(const std::string& path) {
    auto f = open_file(path);
    std::vector<std::pair<std::string, std::string>> out;
    try {
        auto grids = f.readAllGridMetadata();
        for (const auto& g : *grids) out.emplace_back(g->getName(), short_type(*g));
    } catch (const std::exception& e) {
        throw Error(ErrorCode::CorruptData, "'" + path + "': cannot read the grid list: " + e.what());
    }
    return out;
}

Volume read_vdb(const std::string& path, const VolumeReadOptions& options) {
    const std::string what = "'" + path + "'";
    auto f = open_file(path);
    openvdb::GridBase::Ptr grid;
    std::string name = options.grid;
    try {
        auto metas = f.readAllGridMetadata();
        std::vector<std::string> scalar;
        std::string all;
        for (const auto& g : *metas) {
            if (is_scalar_type(short_type(*g))) scalar.push_back(g->getName());
            all += (all.empty() ? "" : ", ") + g->getName() + " (" + short_type(*g) + ")";
        }
        if (name.empty()) {
            if (scalar.size() != 1)
                throw Error(scalar.empty() ? ErrorCode::NotFound : ErrorCode::InvalidArgument,
                            what + (scalar.empty() ? ": holds no scalar grid" : ": holds several scalar grids") +
                                " (grids: " + (all.empty() ? "none" : all) + "); choose one with --grid NAME");
            name = scalar[0];
        }
        bool found = false;
        for (const auto& g : *metas)
            if (g->getName() == name) {
                found = true;
                if (!is_scalar_type(short_type(*g)))
                    throw Error(ErrorCode::UnsupportedFeature,
                                what + ": grid '" + name + "' holds " + short_type(*g) +
                                    " values; tetlod reads float, double, int32, int64 and bool grids");
            }
        if (!found)
            throw Error(ErrorCode::NotFound,
                        what + ": no grid named '" + name + "' (grids: " + (all.empty() ? "none" : all) + ")");
        grid = f.readGrid(name);
        f.close();
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(ErrorCode::CorruptData, what + ": cannot read grid '" + name + "': " + e.what());
    }

    // Transform: linear, diagonal, positive scale.
    const openvdb::math::Transform& xf = grid->transform();
    if (!xf.isLinear())
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": grid '" + name + "' has a non-linear transform (" + xf.mapType() +
                        "); tetlod grids are regular");
    const openvdb::Mat4d m = xf.baseMap()->getAffineMap()->getMat4();
    Vec3 spacing{1, 1, 1};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            double v = m(r, c);
            if (r == c ? !(v > 0 && std::isfinite(v)) : v != 0)
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": grid '" + name + "' has a rotated, sheared or flipped transform (" +
                                xf.mapType() + "); tetlod grids are axis-aligned with positive spacing");
        }
    for (int a = 0; a < 3; ++a) spacing[a] = m(a, a);

    // Dense extent.
    openvdb::CoordBBox active = grid->evalActiveVoxelBoundingBox();
    Extent ext;
    bool have_dims = false;
    if (auto meta = (*grid)["dims_xyz"]) {
        auto n = integers_in(meta->str());
        if (n.size() == 3 && n[0] > 0 && n[1] > 0 && n[2] > 0 && n[0] <= kMaxAxisSize && n[1] <= kMaxAxisSize &&
            n[2] <= kMaxAxisSize) {
            openvdb::CoordBBox declared(openvdb::Coord(0, 0, 0),
                                        openvdb::Coord(static_cast<int32_t>(n[0] - 1), static_cast<int32_t>(n[1] - 1),
                                                       static_cast<int32_t>(n[2] - 1)));
            if (active.empty() || declared.isInside(active)) {
                ext.min = declared.min();
                ext.dims = Dims{n[0], n[1], n[2]};
                have_dims = true;
            }
        }
    }
    if (!have_dims) {
        if (active.empty())
            throw Error(ErrorCode::CorruptData,
                        what + ": grid '" + name + "' has no active voxels and no dims_xyz metadata");
        ext.min = active.min();
        openvdb::Coord d = active.dim();
        ext.dims = Dims{d.x(), d.y(), d.z()};
    }
    validate_dims(ext.dims, what + " grid '" + name + "'");

    Volume vol;
    try {
        if (grid->isType<openvdb::FloatGrid>()) {
            vol = Volume::allocate(ext.dims, ValueType::F32);
            fill_dense(*openvdb::gridConstPtrCast<openvdb::FloatGrid>(grid), ext, vol, what);
        } else if (grid->isType<openvdb::DoubleGrid>()) {
            vol = Volume::allocate(ext.dims, ValueType::F64);
            fill_dense(*openvdb::gridConstPtrCast<openvdb::DoubleGrid>(grid), ext, vol, what);
        } else if (grid->isType<openvdb::Int32Grid>()) {
            vol = Volume::allocate(ext.dims, ValueType::I32);
            fill_dense(*openvdb::gridConstPtrCast<openvdb::Int32Grid>(grid), ext, vol, what);
        } else if (grid->isType<openvdb::Int64Grid>()) {
            vol = Volume::allocate(ext.dims, ValueType::F64);
            fill_dense(*openvdb::gridConstPtrCast<openvdb::Int64Grid>(grid), ext, vol, what);
            // tetlod volumes hold at most 32-bit integers: the declared type, else
            // i32, else u32 (u32 volumes are written as Int64 grids).
            std::optional<ValueType> declared;
            if (auto t = (*grid)["tetlod_value_type"]) declared = parse_value_type(t->str());
            if (!(declared && !is_float(*declared) && try_narrow(vol, *declared)) && !try_narrow(vol, ValueType::I32) &&
                !try_narrow(vol, ValueType::U32))
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": Int64 grid '" + name + "' holds values that do not fit a 32-bit integer");
        } else if (grid->isType<openvdb::BoolGrid>()) {
            vol = Volume::allocate(ext.dims, ValueType::U8);
            fill_dense(*openvdb::gridConstPtrCast<openvdb::BoolGrid>(grid), ext, vol, what);
        } else {
            throw Error(ErrorCode::UnsupportedFeature,
                        what + ": grid '" + name + "' has an unsupported type " + grid->type());
        }
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(ErrorCode::CorruptData, what + ": cannot read grid '" + name + "': " + e.what());
    }

    openvdb::Vec3d o = xf.indexToWorld(ext.min);
    vol.spacing = options.spacing.value_or(spacing);
    vol.origin = options.origin.value_or(Vec3{o.x(), o.y(), o.z()});
    vol.field_name = name;
    for (auto it = grid->beginMeta(); it != grid->endMeta(); ++it) {
        const std::string& k = it->first;
        if (is_internal_meta(k) || is_structural_meta(k) || !it->second) continue;
        vol.metadata[k] = it->second->str();
    }
    if (auto u = (*grid)["units"]) vol.units = u->str();
    // An integer volume stored as float (OpenVDB has no 8/16-bit grids) gets its
    // type back when the file says what it was and every value converts exactly.
    for (const char* key : {"tetlod_value_type", "original_dtype"}) {
        if (auto t = (*grid)[key]) {
            if (auto vt = parse_value_type(t->str())) try_narrow(vol, *vt);
            break;
        }
    }
    return vol;
}

namespace {

template <class GridT, class Src>
typename GridT::Ptr make_grid(const Volume& vol) {
    using V = typename GridT::ValueType;
    typename GridT::Ptr grid = GridT::create(V(0));
    auto acc = grid->getAccessor();
    const Src* src = vol.as<Src>();
    const V bg = V(0);
    for (int64_t z = 0; z < vol.dims.z; ++z)
        for (int64_t y = 0; y < vol.dims.y; ++y)
            for (int64_t x = 0; x < vol.dims.x; ++x) {
                const V v = static_cast<V>(src[vol.dims.index(x, y, z)]);
                // Bitwise, so -0.0 and NaN stay active and come back exactly.
                if (std::memcmp(&v, &bg, sizeof(V)) == 0) continue;
                acc.setValue(openvdb::Coord(static_cast<int32_t>(x), static_cast<int32_t>(y), static_cast<int32_t>(z)), v);
            }
    return grid;
}

}  // namespace

void write_vdb(const Volume& vol, const std::string& path) {
    const std::string what = "'" + path + "'";
    validate_dims(vol.dims, what);
    if (vol.data.size() != static_cast<std::size_t>(vol.dims.count()) * value_size(vol.type))
        throw Error(ErrorCode::InvalidArgument, what + ": volume data size does not match its dims");
    if (vol.dims.x > INT32_MAX || vol.dims.y > INT32_MAX || vol.dims.z > INT32_MAX)
        throw Error(ErrorCode::TooLarge, what + ": dims exceed OpenVDB coordinates");
    for (int a = 0; a < 3; ++a)
        if (!(vol.spacing[a] > 0 && std::isfinite(vol.spacing[a])))
            throw Error(ErrorCode::InvalidArgument, what + ": spacing must be positive for an OpenVDB transform");
    openvdb::initialize();

    openvdb::GridBase::Ptr grid;
    switch (vol.type) {
        case ValueType::F32: grid = make_grid<openvdb::FloatGrid, float>(vol); break;
        case ValueType::F64: grid = make_grid<openvdb::DoubleGrid, double>(vol); break;
        case ValueType::U8: grid = make_grid<openvdb::Int32Grid, uint8_t>(vol); break;
        case ValueType::I8: grid = make_grid<openvdb::Int32Grid, int8_t>(vol); break;
        case ValueType::U16: grid = make_grid<openvdb::Int32Grid, uint16_t>(vol); break;
        case ValueType::I16: grid = make_grid<openvdb::Int32Grid, int16_t>(vol); break;
        case ValueType::I32: grid = make_grid<openvdb::Int32Grid, int32_t>(vol); break;
        case ValueType::U32: grid = make_grid<openvdb::Int64Grid, uint32_t>(vol); break;
    }
    grid->setName(vol.field_name.empty() ? "density" : vol.field_name);
    const Vec3& s = vol.spacing;
    const Vec3& o = vol.origin;
    const double z = 0.0, one = 1.0;
    openvdb::Mat4d m(s[0], z, z, z, z, s[1], z, z, z, z, s[2], z, o[0], o[1], o[2], one);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    for (const auto& [k, v] : vol.metadata)
        if (!is_internal_meta(k) && !is_structural_meta(k)) grid->insertMeta(k, openvdb::StringMetadata(v));
    grid->insertMeta("dims_xyz", openvdb::Vec3IMetadata(openvdb::Vec3i(static_cast<int32_t>(vol.dims.x),
                                                                       static_cast<int32_t>(vol.dims.y),
                                                                       static_cast<int32_t>(vol.dims.z))));
    grid->insertMeta("tetlod_value_type", openvdb::StringMetadata(value_type_name(vol.type)));
    if (!vol.units.empty()) grid->insertMeta("units", openvdb::StringMetadata(vol.units));

    // The library writes the file itself: a temporary file beside the target
    // (symlinks followed), renamed over it (core AtomicPath: output policy, no
    // streams, devices or FIFOs).
    AtomicPath target(path, "OpenVDB");
    try {
        openvdb::io::File out(target.temp_path());
        openvdb::GridPtrVec grids{grid};
        out.write(grids);
        out.close();
    } catch (const std::exception& e) {
        throw Error(ErrorCode::IoError, "cannot write " + what + ": " + e.what());
    }
    target.commit();
}

}  // namespace tetlod
