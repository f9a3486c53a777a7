// METADATA section: fixed geometry block + two sorted key/value lists (spec §5).
#include "tetlod/format/metadata.hpp"

#include <cmath>

#include "tetlod/format/byte_io.hpp"

namespace tetlod::tlod {

std::string Metadata::field_name() const {
    auto it = format_keys.find(kKeyFieldName);
    return it == format_keys.end() ? std::string("value") : it->second;
}

std::string Metadata::units() const {
    auto it = format_keys.find(kKeyFieldUnits);
    return it == format_keys.end() ? std::string() : it->second;
}

static void put_list(std::vector<std::byte>& out, const std::map<std::string, std::string>& kv) {
    for (const auto& [k, v] : kv) {
        put_u32(out, static_cast<uint32_t>(k.size()));
        put_u32(out, static_cast<uint32_t>(v.size()));
        put_bytes(out, k);
        put_bytes(out, v);
    }
}

std::vector<std::byte> serialize_metadata(const Metadata& m) {
    auto check = [](const std::map<std::string, std::string>& kv) {
        if (kv.size() > kMaxMetadataEntries)
            throw Error(ErrorCode::InvalidArgument, "too many metadata keys");
        for (const auto& [k, v] : kv) {
            if (k.empty() || k.size() > kMaxKeyBytes)
                throw Error(ErrorCode::InvalidArgument, "metadata key '" + k.substr(0, 40) +
                                                            "' is empty or longer than 65535 bytes");
            if (v.size() > 0xFFFFFFFFu)
                throw Error(ErrorCode::InvalidArgument, "metadata value of '" + k + "' is too long");
        }
    };
    check(m.format_keys);
    check(m.user_keys);
    std::vector<std::byte> out;
    put_u64(out, static_cast<uint64_t>(m.dims.x));
    put_u64(out, static_cast<uint64_t>(m.dims.y));
    put_u64(out, static_cast<uint64_t>(m.dims.z));
    put_u8(out, static_cast<uint8_t>(m.type));
    for (int i = 0; i < 7; ++i) put_u8(out, 0);
    for (double d : m.spacing) put_f64(out, d);
    for (double d : m.origin) put_f64(out, d);
    put_f64(out, m.value_range[0]);
    put_f64(out, m.value_range[1]);
    put_u32(out, static_cast<uint32_t>(m.format_keys.size()));
    put_u32(out, static_cast<uint32_t>(m.user_keys.size()));
    put_list(out, m.format_keys);
    put_list(out, m.user_keys);
    // Never write what parse_metadata would refuse (e.g. a NaN origin from an
    // input file): the container would be unreadable by its own reader.
    if (auto back = parse_metadata(out); !back)
        raise(with_context("refusing to write metadata the reader would refuse: ", back.failure()));
    return out;
}

Expected<Metadata> parse_metadata(std::span<const std::byte> raw) {
    ByteReader r(raw);
    Metadata m;
    uint64_t d[3];
    for (auto& v : d) v = r.u64();
    const uint8_t type = r.u8();
    uint64_t reserved = r.le(7);
    for (double& s : m.spacing) s = r.f64();
    for (double& o : m.origin) o = r.f64();
    m.value_range[0] = r.f64();
    m.value_range[1] = r.f64();
    const uint32_t nf = r.u32();
    const uint32_t nu = r.u32();
    if (!r.ok()) return fail(ErrorCode::Truncated, "METADATA: shorter than its fixed part");
    if (reserved != 0) return fail(ErrorCode::CorruptData, "METADATA: reserved bytes are not zero");
    for (int a = 0; a < 3; ++a)
        if (d[a] < 1 || d[a] > uint64_t(kMaxAxisSize))
            return fail(d[a] < 1 ? ErrorCode::CorruptData : ErrorCode::TooLarge,
                        "METADATA: dimension " + std::to_string(a) + " is " + std::to_string(d[a]) +
                            " (must be 1.." + std::to_string(kMaxAxisSize) + ")");
    m.dims = Dims{int64_t(d[0]), int64_t(d[1]), int64_t(d[2])};
    if (m.dims.count() > kMaxVolumePoints)
        return fail(ErrorCode::TooLarge, "METADATA: " + std::to_string(m.dims.count()) +
                                             " grid points exceed the limit");
    if (type < 1 || type > 8)
        return fail(ErrorCode::CorruptData, "METADATA: unknown value type " + std::to_string(type));
    m.type = static_cast<ValueType>(type);
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(m.spacing[a]) || !(m.spacing[a] > 0) || !std::isfinite(m.origin[a]))
            return fail(ErrorCode::CorruptData, "METADATA: spacing must be finite and positive, origin finite");
    if (!(m.value_range[0] <= m.value_range[1]))
        return fail(ErrorCode::CorruptData, "METADATA: value range min > max");
    // Each entry takes at least 9 bytes: the counts are bounded by what remains.
    if (nf > kMaxMetadataEntries || nu > kMaxMetadataEntries ||
        (uint64_t(nf) + nu) * 9 > r.remaining())
        return fail(ErrorCode::CorruptData, "METADATA: key counts exceed the section");
    for (int list = 0; list < 2; ++list) {
        auto& kv = list == 0 ? m.format_keys : m.user_keys;
        const uint32_t n = list == 0 ? nf : nu;
        std::string prev;
        for (uint32_t i = 0; i < n; ++i) {
            const uint32_t kl = r.u32();
            const uint32_t vl = r.u32();
            if (!r.ok() || kl > r.remaining() || vl > r.remaining() - kl)
                return fail(ErrorCode::Truncated, "METADATA: key/value runs past the section");
            if (kl == 0 || kl > kMaxKeyBytes)
                return fail(ErrorCode::CorruptData, "METADATA: key length " + std::to_string(kl));
            std::string k = r.str(kl);
            std::string v = r.str(vl);
            if (i > 0 && !(prev < k))
                return fail(ErrorCode::CorruptData,
                            "METADATA: keys are not strictly increasing ('" + k.substr(0, 40) + "')");
            prev = k;
            kv.emplace(std::move(k), std::move(v));
        }
    }
    if (!r.at_end()) return fail(ErrorCode::CorruptData, "METADATA: trailing bytes");
    return m;
}

Metadata metadata_for_volume(const Volume& v) { return metadata_for_volume(v, v.range()); }

Metadata metadata_for_volume(const Volume& v, std::array<double, 2> range) {
    Metadata m;
    m.dims = v.dims;
    m.type = v.type;
    m.spacing = v.spacing;
    m.origin = v.origin;
    m.value_range = range;
    m.format_keys[kKeyFieldName] = v.field_name;
    if (!v.units.empty()) m.format_keys[kKeyFieldUnits] = v.units;
    m.user_keys = v.metadata;
    return m;
}

}  // namespace tetlod::tlod
