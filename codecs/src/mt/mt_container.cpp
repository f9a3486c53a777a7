// MT <-> .tlod sections (spec/tlod-format.md §10). MT_HEADER holds the 48-byte
// header of encode_mt verbatim, MT_STRUCTURE its zstd payload verbatim (stored
// as is, not flagged ZSTD: the container does not decompress it), so decode_mt
// reads their concatenation. Next to an HT the payload's field stream is empty
// and the field is the HT's, decoded bit-exact.
#include "tetlod/codecs/mt/mt_container.hpp"

#include <cstring>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/byte_io.hpp"

namespace tetlod {

namespace {
constexpr std::size_t kMtHeaderSize = 48;
}

bool container_has_mt(const tlod::ContainerReader& r) {
    return ((r.header().required_features | r.header().optional_features) & tlod::kFeatureMt) != 0;
}

void encode_mt_container(const MtModel& model, const tlod::Metadata& meta, tlod::ContainerWriter& w,
                         bool with_ht, const MtEncodeOptions& options) {
    const Volume& f = model.field();
    if (f.type != meta.type || !(f.dims == meta.dims))
        throw Error(ErrorCode::InvalidArgument, "metadata does not describe the MT's volume");
    MtEncodeOptions o = options;
    o.include_field = !with_ht;
    if (o.field_error > 0 && !with_ht)
        throw Error(ErrorCode::InvalidArgument, "a lossy field is the HT's: an MT alone stores its field losslessly");
    // Beside a lossy HT (encode_ht set LOSSY) the MT's errors must include E.
    const bool lossy = with_ht && (w.required_features() & tlod::kFeatureLossy) != 0;
    if (lossy != (o.field_error > 0))
        throw Error(ErrorCode::InvalidArgument,
                    lossy ? "an MT beside a lossy HT needs the field's E (MtEncodeOptions::field_error)"
                          : "MtEncodeOptions::field_error is for an MT beside a lossy HT");
    const std::vector<uint8_t> bytes = encode_mt(model, o);
    if (bytes.size() < kMtHeaderSize) throw Error(ErrorCode::InvalidArgument, "MT encoding too short");
    const auto* b = reinterpret_cast<const std::byte*>(bytes.data());
    std::vector<std::byte> head(b, b + kMtHeaderSize), body(b + kMtHeaderSize, b + bytes.size());
    // Next to an HT the MT is optional: a reader without MT support skips its
    // non-critical sections and still reads the HT.
    const uint32_t flags = with_ht ? 0 : tlod::kSectionCritical;
    if (with_ht) {
        // The HT's features stay (LOSSY); a lossy file says its MT's errors include E.
        w.set_features(w.required_features() | (lossy ? tlod::kFeatureLossyMt : 0), tlod::kFeatureMt);
    } else {
        w.set_features(tlod::kFeatureMt);
        w.add(tlod::kSectionMetadata, tlod::kSectionCritical, 0, 0, tlod::serialize_metadata(meta), o.zstd_level);
    }
    const uint64_t hs = head.size(), bs = body.size();
    w.add_stored(tlod::kSectionMtHeader, flags, 0, 0, std::move(head), hs);
    w.add_stored(tlod::kSectionMtStructure, flags, 0, 0, std::move(body), bs);
}

Expected<MtLayout> read_mt_layout(tlod::ContainerReader& r) {
    const std::string where = r.name() + ": ";
    const auto& h = r.header();
    if (!container_has_mt(r)) return fail(ErrorCode::NotFound, where + "the container holds no MT model");
    if ((h.required_features & tlod::kFeatureMt) && (h.required_features & tlod::kFeatureHt))
        return fail(ErrorCode::CorruptData, where + "MT must be an optional feature next to an HT");
    if ((h.optional_features & tlod::kFeatureMt) && !(h.required_features & tlod::kFeatureHt))
        return fail(ErrorCode::CorruptData, where + "an MT without an HT must be a required feature");
    MtLayout L;
    L.with_ht = (h.required_features & tlod::kFeatureHt) != 0;
    // A lossy field is the HT's (spec §5.1): an MT alone carries its samples as they are.
    if ((h.required_features & tlod::kFeatureLossy) && !L.with_ht)
        return fail(ErrorCode::CorruptData, where + "the LOSSY feature without an HT (an MT alone stores its field losslessly)");
    const auto& secs = r.sections();
    std::vector<std::size_t> known;
    for (std::size_t i = 0; i < secs.size(); ++i)
        if (tlod::is_known_section_type(secs[i].type)) known.push_back(i);
    if (known.empty() || secs[known[0]].type != tlod::kSectionMetadata)
        return fail(ErrorCode::CorruptData, where + "METADATA must be the first known section");
    // The MT's two sections are the last known ones, header first, exactly once each.
    std::size_t nh = 0, ns = 0;
    for (std::size_t i : known) {
        nh += secs[i].type == tlod::kSectionMtHeader;
        ns += secs[i].type == tlod::kSectionMtStructure;
    }
    if (nh != 1 || ns != 1 || known.size() < 3 || secs[known[known.size() - 2]].type != tlod::kSectionMtHeader ||
        secs[known.back()].type != tlod::kSectionMtStructure)
        return fail(ErrorCode::CorruptData, where + "MT_HEADER then MT_STRUCTURE must be the last known sections");
    if (!L.with_ht && known.size() != 3)
        return fail(ErrorCode::CorruptData, where + "HT sections in a file without the HT feature");
    L.header_section = known[known.size() - 2];
    L.structure_section = known.back();
    const uint32_t want_flags = L.with_ht ? 0 : tlod::kSectionCritical;
    for (std::size_t i : {L.header_section, L.structure_section})
        if (secs[i].flags != want_flags || secs[i].arg0 != 0 || secs[i].arg1 != 0)
            return fail(ErrorCode::CorruptData, where + "section " + std::to_string(i) +
                                                    ": MT section flags or arguments not as specified");
    auto mraw = r.read_section(known[0]);
    if (!mraw) return mraw.failure();
    auto meta = tlod::parse_metadata(*mraw);
    if (!meta) return with_context(where, meta.failure());
    L.metadata = std::move(*meta);
    auto hraw = r.read_section(L.header_section);
    if (!hraw) return hraw.failure();
    if (hraw->size() != kMtHeaderSize)
        return fail(ErrorCode::CorruptData, where + "MT_HEADER has " + std::to_string(hraw->size()) +
                                                " bytes, expected 48");
    const std::vector<std::byte>& hb = *hraw;
    if (std::memcmp(hb.data(), "TLMT", 4) != 0) return fail(ErrorCode::CorruptData, where + "MT_HEADER: bad magic");
    const uint64_t version = tlod::load_le(hb.data() + 4, 2), flags = tlod::load_le(hb.data() + 6, 2);
    if (version < 1 || version > kMtCodecVersion)
        return fail(ErrorCode::UnsupportedFeature, where + "MT_HEADER: unknown MT coding version " +
                                                       std::to_string(version));
    if (flags != (L.with_ht ? 0u : 1u))
        return fail(ErrorCode::CorruptData, where + "MT_HEADER: FIELD_INCLUDED must be set exactly when there is no HT");
    const Dims d{int64_t(tlod::load_le(hb.data() + 8, 4)), int64_t(tlod::load_le(hb.data() + 12, 4)),
                 int64_t(tlod::load_le(hb.data() + 16, 4))};
    if (!(d == L.metadata.dims) || tlod::load_le(hb.data() + 20, 1) != uint64_t(L.metadata.type))
        return fail(ErrorCode::CorruptData, where + "MT_HEADER: dims or value type differ from METADATA");
    L.error_mantissa_bits = int(tlod::load_le(hb.data() + 21, 1));
    L.base_tets = uint32_t(tlod::load_le(hb.data() + 24, 4));
    L.updates = uint32_t(tlod::load_le(hb.data() + 28, 4));
    if (tlod::load_le(hb.data() + 40, 8) != secs[L.structure_section].stored_size)
        return fail(ErrorCode::CorruptData, where + "MT_HEADER: payload size differs from MT_STRUCTURE's");
    return L;
}

Expected<MtModel> decode_mt_container(tlod::ContainerReader& r) {
    auto L = read_mt_layout(r);
    if (!L) return L.failure();
    Volume field;
    double field_error = 0;  // a lossy file's E: its update errors include it, its reference tets state it
    if (L->with_ht) {
        auto ht = read_ht_layout(r);
        if (!ht) return ht.failure();
        field_error = ht->max_error;
        auto v = decode_volume(r);
        if (!v) return v.failure();
        field = std::move(*v);
    }
    auto head = r.read_section(L->header_section);
    if (!head) return head.failure();
    auto body = r.read_section(L->structure_section);
    if (!body) return body.failure();
    std::vector<uint8_t> bytes(head->size() + body->size());
    std::memcpy(bytes.data(), head->data(), head->size());
    if (!body->empty()) std::memcpy(bytes.data() + head->size(), body->data(), body->size());
    auto m = decode_mt(bytes, L->with_ht ? &field : nullptr);
    if (!m) return with_context(r.name() + ": MT sections: ", m.failure());
    // Spec §5.1: beside a lossy HT every stored update error includes E, so none is
    // below it; one that is comes from a writer that did not add E (its bounds would
    // be those of the stored field, not of the original).
    if (field_error > 0)
        for (const MtSplit& u : m->updates())
            if (!(double(u.error) >= field_error))
                return fail(ErrorCode::CorruptData, r.name() + ": MT sections: an update error (" +
                                                        std::to_string(u.error) + ") below the field's E (" +
                                                        std::to_string(field_error) +
                                                        "): the MT's bounds do not include the field's loss");
    m->set_field_error_bound(field_error);
    return m;
}

MtModel load_mt_model(const std::string& path) {
    auto r = tlod::ContainerReader::open(path).take();
    return decode_mt_container(r).take();
}

}  // namespace tetlod
