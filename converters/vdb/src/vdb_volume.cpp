// OpenVDB volume reader and writer (OpenVDB 10 library API). The only file in
// tetlod that includes openvdb.h. See tetlod/converters/vdb.hpp for the rules.
#include "tetlod/converters/vdb.hpp"

#include <openvdb/openvdb.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <fcntl.h>
#include <optional>
#include <set>
#include <sys/stat.h>
#include <unistd.h>

#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_planes.hpp"
#include "tetlod/core/isolated_volume.hpp"
#include "tetlod/core/regular_file.hpp"
#include "vdb_read_guard.hpp"

namespace tetlod {

namespace {

// OpenVDB's own bookkeeping metadata: statistics written with the file and
// per-grid flags the library interprets. None of it describes the field.
bool is_internal_meta(const std::string& k) {
    return k.rfind("file_", 0) == 0 || k == "name" || k == "is_saved_as_half_float" || k == "is_local_space" ||
           k == "vector_type";
}

// Metadata key naming the grid type a volume was read from ("float", ...), so
// that writing it again gives the same grid type (FloatGrid stays FloatGrid).
constexpr const char* kGridTypeKey = "vdb:grid_type";

// Names the reader turns into Volume fields and the writer owns.
bool is_structural_meta(const std::string& k) {
    return k == "dims_xyz" || k == "tetlod_value_type" || k == "units";
}

std::string short_type(const openvdb::GridBase& g) { return g.valueType(); }

bool is_scalar_type(const std::string& t) {
    return t == "float" || t == "double" || t == "int32" || t == "int64" || t == "bool";
}

openvdb::io::File open_file(const std::string& path) {
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

template <class G>
struct GridKind {
    using Grid = G;
};

// The scalar grid classes tetlod reads and writes: calls f(GridKind<G>{}) for
// the first G of FloatGrid, DoubleGrid, Int32Grid, Int64Grid, BoolGrid that
// pick(GridKind<G>{}) accepts, else returns none(). One list for the whole
// read, the plane reader and the writer.
template <class Pick, class F, class None>
decltype(auto) dispatch_scalar_grid(Pick&& pick, F&& f, None&& none) {
    if (pick(GridKind<openvdb::FloatGrid>{})) return f(GridKind<openvdb::FloatGrid>{});
    if (pick(GridKind<openvdb::DoubleGrid>{})) return f(GridKind<openvdb::DoubleGrid>{});
    if (pick(GridKind<openvdb::Int32Grid>{})) return f(GridKind<openvdb::Int32Grid>{});
    if (pick(GridKind<openvdb::Int64Grid>{})) return f(GridKind<openvdb::Int64Grid>{});
    if (pick(GridKind<openvdb::BoolGrid>{})) return f(GridKind<openvdb::BoolGrid>{});
    return none();
}

// The grid's class test, as a pick for dispatch_scalar_grid.
auto is_grid_of(const openvdb::GridBase& g) {
    return [&g](auto kind) { return g.isType<typename decltype(kind)::Grid>(); };
}

// The type a grid's values are staged in by the whole read (Int64 as double,
// narrowed afterwards; bool as u8), and the plane reader's starting point.
template <class V>
constexpr ValueType staged_type() {
    if constexpr (std::is_same_v<V, bool>) return ValueType::U8;
    else if constexpr (std::is_same_v<V, float>) return ValueType::F32;
    else if constexpr (std::is_same_v<V, int32_t>) return ValueType::I32;
    else return ValueType::F64;
}

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

namespace {

// What the library may read: a regular file whose layout the guard accepts.
// Returns the file size.
uint64_t check_before_library(const std::string& path) {
    require_regular_file(path, "OpenVDB file");
    std::error_code ec;
    const uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + ec.message());
    return size;
}

// check_before_library, then the guard's checks of the layout and of the
// selected grid's claims (what a read of one grid needs). Returns the file size.
uint64_t check_grid_read(const std::string& path, const VolumeReadOptions& options) {
    const uint64_t size = check_before_library(path);
    const auto layout = vdb_guard::check_vdb_layout(path, size);
    vdb_guard::check_selected_grid_claims(layout, options.grid, size, "'" + path + "'");
    return size;
}

// The isolated child's task for reading `path` (`size` bytes) under `isolation`'s limits.
IsolatedTask vdb_task(const std::string& path, const IsolationOptions& isolation, uint64_t size) {
    return IsolatedTask{"OpenVDB", path, isolation_time_limit(isolation, size), isolation_memory_limit(isolation, size)};
}

std::vector<std::pair<std::string, std::string>> list_vdb_grids_here(const std::string& path) {
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

// The grid a read takes and everything known before its samples: the choice
// of grid, its transform, the dense extent (checked against the file's size)
// and the header (geometry, names, metadata; dims of the extent, the type of
// the staging volume). Shared by the whole read and the plane reader.
struct GridSource {
    openvdb::GridBase::Ptr grid;
    std::string name;
    std::string what;  // "'path'"
    Extent ext;
    Volume header;
};

GridSource open_vdb_grid(const std::string& path, const VolumeReadOptions& options, uint64_t file_size) {
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
        std::string raw;
        if (meta->typeName() == "vec3i") {
            const openvdb::Vec3i d = grid->metaValue<openvdb::Vec3i>("dims_xyz");
            raw.resize(12);
            std::memcpy(raw.data(), d.asPointer(), 12);
        } else {
            raw = meta->str();
        }
        const Dims nd = vdb_guard::parse_dims_xyz(meta->typeName(), raw, what + " grid '" + name + "'");
        const int64_t n[3] = {nd.x, nd.y, nd.z};
        {
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
    vdb_guard::check_dense_bound(ext.dims, vdb_guard::dense_value_bytes(short_type(*grid)), file_size,
                                 what + " grid '" + name + "'",
                                 have_dims ? "metadata dims_xyz" : "the active voxels' bounding box");

    GridSource src;
    src.grid = grid;
    src.name = name;
    src.what = what;
    src.ext = ext;
    Volume& h = src.header;
    h.dims = ext.dims;
    openvdb::Vec3d o = xf.indexToWorld(ext.min);
    h.spacing = options.spacing.value_or(spacing);
    h.origin = options.origin.value_or(Vec3{o.x(), o.y(), o.z()});
    h.field_name = name;
    for (auto it = grid->beginMeta(); it != grid->endMeta(); ++it) {
        const std::string& k = it->first;
        if (is_internal_meta(k) || is_structural_meta(k) || !it->second) continue;
        h.metadata[k] = it->second->str();
    }
    if (auto u = (*grid)["units"]) h.units = u->str();
    h.metadata[kGridTypeKey] = short_type(*grid);  // write_vdb writes this grid type again
    return src;
}

// The read itself, in whichever process read_vdb chose.
Volume read_vdb_here(const std::string& path, const VolumeReadOptions& options, uint64_t file_size) {
    GridSource src = open_vdb_grid(path, options, file_size);
    const openvdb::GridBase::Ptr& grid = src.grid;
    const std::string& name = src.name;
    const std::string& what = src.what;
    const Extent& ext = src.ext;
    Volume vol;
    try {
        dispatch_scalar_grid(
            is_grid_of(*grid),
            [&](auto kind) {
                using G = typename decltype(kind)::Grid;
                using V = typename G::ValueType;
                vol = Volume::allocate(ext.dims, staged_type<V>());
                fill_dense(*openvdb::gridConstPtrCast<G>(grid), ext, vol, what);
                if constexpr (std::is_same_v<V, int64_t>) {
                    // tetlod volumes hold at most 32-bit integers: the declared type, else
                    // i32, else u32 (u32 volumes are written as Int64 grids).
                    std::optional<ValueType> declared;
                    if (auto t = (*grid)["tetlod_value_type"]) declared = parse_value_type(t->str());
                    if (!(declared && !is_float(*declared) && try_narrow(vol, *declared)) &&
                        !try_narrow(vol, ValueType::I32) && !try_narrow(vol, ValueType::U32))
                        throw Error(ErrorCode::UnsupportedFeature,
                                    what + ": Int64 grid '" + name + "' holds values that do not fit a 32-bit integer");
                }
            },
            [&] {
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": grid '" + name + "' has an unsupported type " + grid->type());
            });
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(ErrorCode::CorruptData, what + ": cannot read grid '" + name + "': " + e.what());
    }

    vol.spacing = src.header.spacing;
    vol.origin = src.header.origin;
    vol.field_name = src.header.field_name;
    vol.units = src.header.units;
    vol.metadata = src.header.metadata;
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

// ---- plane by plane ----
// The child keeps the grid (sparse) and fills the planes asked for from it, so
// no dense copy of the volume exists on either side. The samples must be the
// whole read's: the same background/active rule as fill_dense and the same
// final type, which the whole read decides by trying every dense value
// (try_narrow); here that set of values is visited sparsely: the background
// when a voxel of the extent is inactive, and every active value inside it.

double as_double(bool v) { return v ? 1.0 : 0.0; }
template <class V>
double as_double(V v) {
    return static_cast<double>(v);
}

// try_narrow's rule for one value.
bool value_fits(ValueType target, double v) {
    return dispatch_value_type(target, [&](auto t) {
        using T = decltype(t);
        if (!std::isfinite(v) && !std::is_floating_point_v<T>) return false;
        if constexpr (!std::is_floating_point_v<T>) {
            if (v < static_cast<double>(std::numeric_limits<T>::min()) ||
                v > static_cast<double>(std::numeric_limits<T>::max()))
                return false;
        }
        const T c = static_cast<T>(v);
        return static_cast<double>(c) == v || (std::isnan(v) && std::isnan(static_cast<double>(c)));
    });
}

template <class GridT>
class GridValues {
public:
    GridValues(const GridT& grid, const Extent& ext) : grid_(grid), box_(box_of(ext)) {
        uint64_t active = 0;
        for_active([&](const openvdb::CoordBBox& b, double) { active += b.volume(); });
        background_shown_ = active < uint64_t(ext.dims.count());
    }
    /// Calls f(value) for every value of the dense volume (repeats allowed).
    template <class F>
    bool all(F&& f) const {
        if (background_shown_ && !f(as_double(grid_.background()))) return false;
        bool ok = true;
        for_active([&](const openvdb::CoordBBox&, double v) { ok = ok && f(v); });
        return ok;
    }

private:
    static openvdb::CoordBBox box_of(const Extent& ext) {
        return openvdb::CoordBBox(ext.min, ext.min + openvdb::Coord(static_cast<int32_t>(ext.dims.x - 1),
                                                                    static_cast<int32_t>(ext.dims.y - 1),
                                                                    static_cast<int32_t>(ext.dims.z - 1)));
    }
    template <class F>
    void for_active(F&& f) const {
        for (auto it = grid_.cbeginValueOn(); it; ++it) {
            openvdb::CoordBBox b;
            it.getBoundingBox(b);  // one voxel, or a whole active tile
            b.intersect(box_);
            if (!b.empty()) f(b, as_double(*it));
        }
    }
    const GridT& grid_;
    openvdb::CoordBBox box_;
    bool background_shown_ = false;
};

// The type read_vdb_here ends with, decided without the dense volume.
template <class GridT>
ValueType planes_type(const GridT& grid, const GridSource& src) {
    using V = typename GridT::ValueType;
    const GridValues<GridT> values(grid, src.ext);
    ValueType type = staged_type<V>();
    auto fits = [&](ValueType target) {
        return target == type || values.all([&](double v) { return value_fits(target, v); });
    };
    if constexpr (std::is_same_v<V, int64_t>) {
        // fill_dense's staging check: the background is always stored.
        auto staged = [&](double v) { return !(v < -std::ldexp(1.0, 53) || v > std::ldexp(1.0, 53)); };
        if (!staged(as_double(grid.background())) || !values.all(staged))
            throw Error(ErrorCode::UnsupportedFeature,
                        src.what + ": Int64 grid '" + src.name + "' holds a value that does not fit a 32-bit integer");
        std::optional<ValueType> declared;
        if (auto t = grid["tetlod_value_type"]) declared = parse_value_type(t->str());
        if (declared && !is_float(*declared) && fits(*declared)) type = *declared;
        else if (fits(ValueType::I32)) type = ValueType::I32;
        else if (fits(ValueType::U32)) type = ValueType::U32;
        else
            throw Error(ErrorCode::UnsupportedFeature,
                        src.what + ": Int64 grid '" + src.name + "' holds values that do not fit a 32-bit integer");
    }
    for (const char* key : {"tetlod_value_type", "original_dtype"}) {
        if (auto t = grid[key]) {
            if (auto vt = parse_value_type(t->str()); vt && fits(*vt)) type = *vt;
            break;
        }
    }
    return type;
}

template <class GridT>
class VdbPlanes final : public VolumePlanes {
public:
    VdbPlanes(GridSource src, typename GridT::ConstPtr grid, ValueType type)
        : src_(std::move(src)), grid_(std::move(grid)), acc_(grid_->getConstAccessor()) {
        src_.header.type = type;
    }

    const Volume& header() const override { return src_.header; }

    void read(int64_t z0, int64_t count, std::byte* dst) override {
        const Dims d = src_.header.dims;
        if (z0 < 0 || count < 0 || count > d.z || z0 > d.z - count)
            throw Error(ErrorCode::InvalidArgument, src_.what + ": planes " + std::to_string(z0) + ".." +
                                                        std::to_string(z0 + count - 1) + " outside the volume");
        using V = typename GridT::ValueType;
        const V bg = grid_->background();
        const openvdb::Coord m = src_.ext.min;
        dispatch_value_type(src_.header.type, [&](auto t) {
            using T = decltype(t);
            for (int64_t z = z0; z < z0 + count; ++z)
                for (int64_t y = 0; y < d.y; ++y)
                    for (int64_t x = 0; x < d.x; ++x) {
                        V v;
                        const openvdb::Coord c(m.x() + int32_t(x), m.y() + int32_t(y), m.z() + int32_t(z));
                        if (!acc_.probeValue(c, v)) v = bg;
                        T out;
                        if constexpr (std::is_same_v<T, V>) out = v;  // the staged type itself: bit for bit
                        else out = static_cast<T>(as_double(v));
                        std::memcpy(dst, &out, sizeof out);
                        dst += sizeof out;
                    }
        });
    }

private:
    GridSource src_;
    typename GridT::ConstPtr grid_;
    typename GridT::ConstAccessor acc_;
};

template <class GridT>
std::unique_ptr<VolumePlanes> make_vdb_planes(GridSource& src) {
    auto grid = openvdb::gridConstPtrCast<GridT>(src.grid);
    const ValueType type = planes_type(*grid, src);
    return std::make_unique<VdbPlanes<GridT>>(std::move(src), std::move(grid), type);
}

std::unique_ptr<VolumePlanes> open_vdb_planes_here(const std::string& path, const VolumeReadOptions& options,
                                                   uint64_t file_size) {
    GridSource src = open_vdb_grid(path, options, file_size);
    const std::string what = src.what, name = src.name;
    try {
        const openvdb::GridBase& g = *src.grid;
        return dispatch_scalar_grid(
            is_grid_of(g),
            [&](auto kind) { return make_vdb_planes<typename decltype(kind)::Grid>(src); },
            [&]() -> std::unique_ptr<VolumePlanes> {
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": grid '" + name + "' has an unsupported type " + g.type());
            });
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(ErrorCode::CorruptData, what + ": cannot read grid '" + name + "': " + e.what());
    }
}

}  // namespace

std::vector<std::pair<std::string, std::string>> list_vdb_grids(const std::string& path) {
    const uint64_t size = check_before_library(path);
    vdb_guard::check_vdb_layout(path, size);
    const IsolatedTask task = vdb_task(path, IsolationOptions{}, size);
    return read_pairs_isolated(task, [&] { return list_vdb_grids_here(path); });
}

Volume read_vdb(const std::string& path, const VolumeReadOptions& options) {
    const uint64_t size = check_grid_read(path, options);
    if (!options.isolation.enabled) return read_vdb_here(path, options, size);
    // OpenVDB overflows its heap on some corrupt files: it reads in a child process.
    const IsolatedTask task = vdb_task(path, options.isolation, size);
    return read_volume_isolated(task, [&] { return read_vdb_here(path, options, size); });
}

std::unique_ptr<VolumePlanes> open_vdb_planes(const std::string& path, const VolumeReadOptions& options) {
    const uint64_t size = check_grid_read(path, options);
    if (!options.isolation.enabled) return open_vdb_planes_here(path, options, size);
    // The child loads the grid under the whole read's limits, then answers plane
    // requests from it; reading a plane allocates nothing.
    const IsolatedTask task = vdb_task(path, options.isolation, size);
    return open_planes_isolated(task, options.isolation, [&] {
        return PlanesInChild{open_vdb_planes_here(path, options, size), uint64_t{16} << 20};
    });
}

namespace {

// The writer reads its samples plane by plane (a volume in memory through
// planes_of), so a streaming decode holds the grid being built and one plane,
// never a dense copy of the volume besides the grid.

template <class GridT, class Src>
typename GridT::Ptr make_grid(VolumePlanes& planes) {
    using V = typename GridT::ValueType;
    const Dims d = planes.header().dims;
    typename GridT::Ptr grid = GridT::create(V(0));
    auto acc = grid->getAccessor();
    std::vector<Src> plane(static_cast<std::size_t>(d.x * d.y));
    const V bg = V(0);
    for (int64_t z = 0; z < d.z; ++z) {
        planes.read(z, 1, reinterpret_cast<std::byte*>(plane.data()));
        for (int64_t y = 0; y < d.y; ++y)
            for (int64_t x = 0; x < d.x; ++x) {
                const V v = static_cast<V>(plane[static_cast<std::size_t>(y * d.x + x)]);
                // Bitwise, so -0.0 and NaN stay active and come back exactly.
                if (std::memcmp(&v, &bg, sizeof(V)) == 0) continue;
                acc.setValue(openvdb::Coord(static_cast<int32_t>(x), static_cast<int32_t>(y), static_cast<int32_t>(z)), v);
            }
    }
    return grid;
}

template <class GridT>
openvdb::GridBase::Ptr make_grid_of(VolumePlanes& planes) {
    return dispatch_value_type(planes.header().type, [&](auto t) -> openvdb::GridBase::Ptr {
        return make_grid<GridT, decltype(t)>(planes);
    });
}

// A pass over the planes (read once more when the grid is built).
bool all_values_within(VolumePlanes& planes, double lo, double hi) {
    const Volume& h = planes.header();
    return dispatch_value_type(h.type, [&](auto t) {
        using T = decltype(t);
        std::vector<T> plane(static_cast<std::size_t>(h.dims.x * h.dims.y));
        for (int64_t z = 0; z < h.dims.z; ++z) {
            planes.read(z, 1, reinterpret_cast<std::byte*>(plane.data()));
            for (const T v : plane)
                if (!(static_cast<double>(v) >= lo && static_cast<double>(v) <= hi)) return false;
        }
        return true;
    });
}

// The grid type to write: the one the volume was read from (metadata
// vdb:grid_type) when it holds every value exactly, else f32 -> float, f64 ->
// double, u32 -> int64, other integers -> int32.
std::string grid_type_for(VolumePlanes& planes) {
    const Volume& vol = planes.header();
    const ValueType t = vol.type;
    const bool small_int = t == ValueType::U8 || t == ValueType::I8 || t == ValueType::U16 || t == ValueType::I16;
    auto it = vol.metadata.find(kGridTypeKey);
    const std::string hint = it == vol.metadata.end() ? "" : it->second;
    if (hint == "float" &&
        (t == ValueType::F32 || small_int || (!is_float(t) && all_values_within(planes, -16777216.0, 16777216.0))))
        return hint;
    if (hint == "double" && (t == ValueType::F64 || t == ValueType::F32 || !is_float(t))) return hint;
    if (hint == "int32" && !is_float(t) && (t != ValueType::U32 || all_values_within(planes, 0, INT32_MAX)))
        return hint;
    if (hint == "int64" && !is_float(t)) return hint;
    if (hint == "bool" && !is_float(t) && all_values_within(planes, 0, 1)) return hint;
    if (t == ValueType::F32) return "float";
    if (t == ValueType::F64) return "double";
    return t == ValueType::U32 ? "int64" : "int32";
}

bool vdb_can_hold_key(const std::string& k) { return !k.empty() && !is_internal_meta(k) && !is_structural_meta(k); }

}  // namespace

std::vector<std::string> vdb_unstorable_keys(const Volume& vol) {
    std::vector<std::string> out;
    for (const auto& [k, v] : vol.metadata)
        if (!vdb_can_hold_key(k)) out.push_back(k);
    return out;
}

void write_vdb(const Volume& vol, const std::string& path) {
    if (vol.data.size() != static_cast<std::size_t>(vol.dims.count()) * value_size(vol.type))
        throw Error(ErrorCode::InvalidArgument, "'" + path + "': volume data size does not match its dims");
    auto planes = planes_of(vol);
    write_vdb(*planes, path);
}

void write_vdb(VolumePlanes& planes, const std::string& path) {
    const Volume& vol = planes.header();
    const std::string what = "'" + path + "'";
    validate_dims(vol.dims, what);
    if (vol.dims.x > INT32_MAX || vol.dims.y > INT32_MAX || vol.dims.z > INT32_MAX)
        throw Error(ErrorCode::TooLarge, what + ": dims exceed OpenVDB coordinates");
    for (int a = 0; a < 3; ++a)
        if (!(vol.spacing[a] > 0 && std::isfinite(vol.spacing[a])))
            throw Error(ErrorCode::InvalidArgument, what + ": spacing must be positive for an OpenVDB transform");
    openvdb::initialize();

    const std::string grid_type = grid_type_for(planes);
    // grid_type is a value type name as GridBase::valueType() gives it.
    openvdb::GridBase::Ptr grid = dispatch_scalar_grid(
        [&](auto kind) {
            return grid_type == openvdb::typeNameAsString<typename decltype(kind)::Grid::ValueType>();
        },
        [&](auto kind) { return make_grid_of<typename decltype(kind)::Grid>(planes); },
        [&] { return make_grid_of<openvdb::Int32Grid>(planes); });
    grid->setName(vol.field_name.empty() ? "density" : vol.field_name);
    const Vec3& s = vol.spacing;
    const Vec3& o = vol.origin;
    const double z = 0.0, one = 1.0;
    openvdb::Mat4d m(s[0], z, z, z, z, s[1], z, z, z, z, s[2], z, o[0], o[1], o[2], one);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    for (const auto& [k, v] : vol.metadata)  // the others: vdb_unstorable_keys()
        if (vdb_can_hold_key(k) && k != kGridTypeKey) grid->insertMeta(k, openvdb::StringMetadata(v));
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
