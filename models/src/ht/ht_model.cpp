// HtModel construction: domain embedding, optional padding, exact errors.
#include "tetlod/models/ht/ht_model.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <cmath>
#include <string>

#include "ht_error_build.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/float_bound.hpp"

namespace tetlod {

HtDomain HtDomain::for_dims(const Dims& dims, bool pad) {
    validate_dims(dims, "HT domain");
    for (int a = 0; a < 3; ++a)
        if (dims[a] < 2)
            throw Error(ErrorCode::InvalidArgument,
                        "a tetrahedral mesh needs at least 2 samples along every axis; axis " +
                            std::string(1, "xyz"[a]) + " has " + std::to_string(dims[a]));
    HtDomain d;
    const int64_t extent = std::max({dims.x, dims.y, dims.z}) - 1;
    d.k = std::bit_width(uint64_t(extent - 1));  // smallest k with 2^k >= extent
    if ((int64_t{1} << d.k) < extent) ++d.k;
    d.L = int32_t{1} << d.k;
    d.source_dims = dims;
    d.padded = pad;
    for (int a = 0; a < 3; ++a) d.box_max[a] = pad ? d.L : int32_t(dims[a] - 1);
    return d;
}

namespace {

/// Extends a volume to (L+1)^3 by repeating the nearest edge sample.
Volume pad_to_cube(const Volume& v, int32_t L) {
    Volume out = Volume::allocate(Dims{L + 1, L + 1, L + 1}, v.type);
    out.spacing = v.spacing;
    out.origin = v.origin;
    out.field_name = v.field_name;
    out.units = v.units;
    out.metadata = v.metadata;
    const std::size_t vs = value_size(v.type);
    for (int64_t z = 0; z <= L; ++z) {
        const int64_t sz = std::min(z, v.dims.z - 1);
        for (int64_t y = 0; y <= L; ++y) {
            const int64_t sy = std::min(y, v.dims.y - 1);
            const std::byte* src = v.data.data() + v.dims.index(0, sy, sz) * vs;
            std::byte* dst = out.data.data() + out.dims.index(0, y, z) * vs;
            std::memcpy(dst, src, v.dims.x * vs);
            for (int64_t x = v.dims.x; x <= L; ++x)
                std::memcpy(dst + x * vs, src + (v.dims.x - 1) * vs, vs);
        }
    }
    return out;
}

void require_finite(const Volume& v) {
    if (!is_float(v.type)) return;
    for (int64_t i = 0; i < v.count(); ++i) {
        const double x = v.value(i);
        if (!std::isfinite(x)) {
            const int64_t px = i % v.dims.x, py = (i / v.dims.x) % v.dims.y,
                          pz = i / (v.dims.x * v.dims.y);
            throw Error(ErrorCode::CorruptData,
                        "the volume holds a non-finite value (" + std::to_string(x) + ") at (" +
                            std::to_string(px) + "," + std::to_string(py) + "," +
                            std::to_string(pz) + "); the HT needs finite values everywhere");
        }
    }
}

}  // namespace

HtModel HtModel::build(Volume volume, const HtBuildOptions& options) {
    if (volume.data.size() != static_cast<std::size_t>(volume.count()) * value_size(volume.type))
        throw Error(ErrorCode::InvalidArgument, "volume data size does not match its dims");
    require_finite(volume);
    HtModel m;
    m.domain_ = HtDomain::for_dims(volume.dims, options.pad);
    auto field = std::make_shared<Volume>(options.pad && !(volume.dims == m.domain_.dims())
                                              ? pad_to_cube(volume, m.domain_.L)
                                              : std::move(volume));
    m.range_ = field->range();
    m.errors_ = std::make_shared<const ZeroedVector<float>>(ht::compute_diamond_errors(*field, m.domain_));
    m.field_ = std::move(field);
    return m;
}

HtModel HtModel::from_parts(Volume field, const HtDomain& domain, ZeroedVector<float> errors, double field_error) {
    const std::array<double, 2> r = field.range();
    return over_shared_parts(std::make_shared<const Volume>(std::move(field)), domain,
                             std::make_shared<const ZeroedVector<float>>(std::move(errors)), r, field_error);
}

HtModel HtModel::over_shared_parts(std::shared_ptr<const Volume> field, const HtDomain& domain,
                                   std::shared_ptr<const ZeroedVector<float>> errors,
                                   std::array<double, 2> range, double field_error) {
    if (!field || !errors) throw Error(ErrorCode::InvalidArgument, "HT model: missing field or errors");
    if (!(field_error >= 0) || !std::isfinite(field_error))
        throw Error(ErrorCode::InvalidArgument, "HT model: the field's error bound must be finite and >= 0");
    if (!(field->dims == domain.dims()))
        throw Error(ErrorCode::CorruptData, "HT field dims do not match the HT domain");
    if (errors->size() != static_cast<std::size_t>(field->count()))
        throw Error(ErrorCode::CorruptData, "HT error array size does not match the HT domain");
    HtDomain expect = HtDomain::for_dims(domain.padded ? domain.source_dims : field->dims, domain.padded);
    if (expect.k != domain.k || expect.box_max != domain.box_max)
        throw Error(ErrorCode::CorruptData, "inconsistent HT domain");
    HtModel m;
    m.domain_ = domain;
    m.field_ = std::move(field);
    m.errors_ = std::move(errors);
    m.range_ = range;
    m.field_error_bound_ = float_at_least(field_error);  // rounded up, as every stated bound
    return m;
}

}  // namespace tetlod
