// The HT layout of a container: METADATA and HT_HEADER validated, the chunk
// sections matched to the chunk list (spec §6).
#include <optional>
#include <utility>

#include "ht_chunk_modes.hpp"
#include "tetlod/codecs/lossy_field.hpp"

namespace tetlod {

using namespace ht_detail;

namespace {

/// Spec §6.4: what a coding-3 chunk section's mode requires of its sizes
/// (range-mode sections then pass the coding-2 checks). `w`: bytes per value.
/// `lattice`: the file has a lattice step (lossy, §6.4 mode 4).
std::optional<std::pair<ErrorCode, std::string>> check_chunk_mode(const tlod::SectionInfo& s, uint64_t n, uint64_t w,
                                                                   bool field, bool lattice) {
    const uint32_t mode = tlod::section_mode(s.flags);
    const bool zstd = (s.flags & tlod::kSectionZstd) != 0;
    auto bad = [](std::string m) { return std::optional{std::pair{ErrorCode::CorruptData, std::move(m)}}; };
    if (mode > kModeRangeExp ||
        ((mode == kModeZeroResidual || mode == kModeLattice || mode == kModeRange2d || mode == kModeStatic) && !field) ||
        (mode == kModeRangeExp && field))
        return std::optional{std::pair{ErrorCode::UnsupportedFeature,
                                       "unknown chunk mode " + std::to_string(mode) +
                                           (field ? " for field values" : " for error codes")}};
    if (n == 0 && (mode != kModeRange || s.raw_size != 0)) return bad("an empty chunk must be an empty range-mode section");
    if (zstd && mode != kModeSamples) return bad(std::string(chunk_mode_name(mode)) + " chunks must not be zstd-compressed");
    if ((mode == kModeConstant || mode == kModeZeroResidual || mode == kModeStatic) && n > kMaxModelledPoints)
        return bad(std::string(chunk_mode_name(mode)) + " chunk of " + std::to_string(n) + " values (at most 2^22)");
    if (mode == kModeConstant && s.raw_size != w)
        return bad("constant chunk of " + std::to_string(s.raw_size) + " bytes, expected " + std::to_string(w));
    if (mode == kModeZeroResidual && s.raw_size != 0) return bad("zero-residual chunk with stored bytes");
    // Tables of at least one used context (10 bytes), a length, two states.
    if (mode == kModeStatic && s.raw_size < kMinStaticBytes)
        return bad("static chunk of " + std::to_string(s.raw_size) + " bytes (at least " +
                   std::to_string(kMinStaticBytes) + ")");
    if (mode == kModeLattice && !lattice)
        return bad("lattice chunk in a file without a lattice step (not LOSSY, or an integer field.max_error below 1)");
    // n * w cannot overflow: n is a chunk's point count (< 2^35), w <= 8.
    if (mode == kModeSamples && s.raw_size != n * w)
        return bad("samples chunk of " + std::to_string(s.raw_size) + " raw bytes, the chunk's " + std::to_string(n) +
                   " values need " + std::to_string(n * w));
    return std::nullopt;
}

}  // namespace

Expected<HtLayout> read_ht_layout(tlod::ContainerReader& r) {
    const std::string where = r.name() + ": ";
    if (!(r.header().required_features & tlod::kFeatureHt))
        return fail(ErrorCode::NotFound, where + "the container holds no HT model");
    const auto& secs = r.sections();
    // Known sections in their required order; unknown non-critical ones skipped.
    std::vector<std::size_t> known;
    // (The MT's sections, spec §10, follow the HT's and are not part of its layout.)
    for (std::size_t i = 0; i < secs.size(); ++i)
        if (tlod::is_known_section_type(secs[i].type) && secs[i].type <= tlod::kSectionHtErrors)
            known.push_back(i);
    if (known.empty() || secs[known[0]].type != tlod::kSectionMetadata)
        return fail(ErrorCode::CorruptData, where + "METADATA must be the first known section");
    auto mraw = r.read_section(known[0]);
    if (!mraw) return mraw.failure();
    auto meta = tlod::parse_metadata(*mraw);
    if (!meta) return with_context(where, meta.failure());
    if (known.size() < 2 || secs[known[1]].type != tlod::kSectionHtHeader)
        return fail(ErrorCode::CorruptData, where + "HT_HEADER must follow METADATA");
    auto hraw = r.read_section(known[1]);
    if (!hraw) return hraw.failure();
    if (hraw->size() != kHtHeaderSize)
        return fail(ErrorCode::CorruptData, where + "HT_HEADER has " + std::to_string(hraw->size()) +
                                                " bytes, expected " + std::to_string(kHtHeaderSize));
    tlod::ByteReader b(*hraw);
    HtLayout L;
    L.metadata = std::move(*meta);
    const int k = b.u8();
    const uint8_t flags = b.u8();
    L.brick_log2 = b.u8();
    L.error_mantissa_bits = b.u8();
    const uint8_t predictor = b.u8();
    const uint8_t coding = b.u8();
    const uint16_t res0 = b.u16();
    uint32_t box[3];
    for (auto& v : box) v = b.u32();
    const uint32_t res1 = b.u32();
    if (flags & ~1u) return fail(ErrorCode::CorruptData, where + "HT_HEADER: reserved flag bits set");
    if (res0 || res1) return fail(ErrorCode::CorruptData, where + "HT_HEADER: reserved fields not zero");
    if (!(predictor == kPredictorCoarseMean && coding == kResidualZigzagPlanes) &&
        !(predictor == kPredictorNeighbours && (coding == kResidualRangeCoder || coding == kResidualChunkModes)))
        return fail(ErrorCode::UnsupportedFeature, where + "HT_HEADER: unknown predictor or residual coding");
    L.residual_coding = coding;
    // Spec §5.1: the LOSSY feature and field.max_error come together; E must
    // be finite and > 0 (a hostile value must not weaken every bound).
    {
        const bool lossy = (r.header().required_features & tlod::kFeatureLossy) != 0;
        const auto key = L.metadata.format_keys.find(tlod::kKeyFieldMaxError);
        const bool has_key = key != L.metadata.format_keys.end();
        if (lossy != has_key)
            return fail(ErrorCode::CorruptData, where + (lossy ? "the LOSSY feature is set without the field.max_error key"
                                                               : "field.max_error given without the LOSSY feature"));
        if (lossy) {
            auto e = parse_max_error(key->second);
            if (!e) return with_context(where, e.failure());
            L.max_error = *e;
        }
    }
    if (L.brick_log2 < 1 || L.brick_log2 > 16 || L.error_mantissa_bits > 7)
        return fail(ErrorCode::CorruptData, where + "HT_HEADER: brick size or error precision out of range");
    const Dims& dims = L.metadata.dims;
    if (dims.x < 2 || dims.y < 2 || dims.z < 2)
        return fail(ErrorCode::CorruptData, where + "an HT needs at least 2 samples per axis");
    auto domain = capture([&] { return HtDomain::for_dims(dims, flags & 1); }, where);
    if (!domain) return domain.failure();
    const HtDomain d = *domain;
    if (d.k != k || uint32_t(d.box_max[0]) != box[0] || uint32_t(d.box_max[1]) != box[1] ||
        uint32_t(d.box_max[2]) != box[2])
        return fail(ErrorCode::CorruptData, where + "HT_HEADER: k or box does not match the volume dims");
    validate_dims(d.dims(), "HT box");
    L.domain = d;
    const Geometry G = geometry_of(d, L.brick_log2);
    // Cheap bound on the chunk count before building the list: each chunk needs
    // two table entries, so a table that is too short is refused here.
    uint64_t expect = 0;
    for (int t = G.k; t >= 0; --t) {
        auto n = G.bricks(t);
        expect += uint64_t(n[0] * n[1] * n[2]);
    }
    if (expect * 2 > known.size() - 2)
        return fail(ErrorCode::CorruptData, where + "the file has " + std::to_string(known.size() - 2) +
                                                " HT chunk sections, the HT_HEADER needs " +
                                                std::to_string(expect * 2));
    L.chunks = chunk_list(G);
    if (L.chunks.size() * 2 != known.size() - 2)
        return fail(ErrorCode::CorruptData, where + "extra sections after the last HT chunk");
    const int W = int(value_size(L.metadata.type));
    const bool has_lattice = dispatch_value_type(L.metadata.type, [&](auto tv) {
        return lattice_step<decltype(tv)>(L.max_error) > 0;
    });
    for (std::size_t i = 0; i < L.chunks.size(); ++i) {
        HtChunk& c = L.chunks[i];
        c.field_section = known[2 + 2 * i];
        c.error_section = known[3 + 2 * i];
        const auto& fs = secs[c.field_section];
        const auto& es = secs[c.error_section];
        if (fs.type != tlod::kSectionHtField || es.type != tlod::kSectionHtErrors ||
            fs.arg0 != uint32_t(c.cycle) || es.arg0 != uint32_t(c.cycle) || fs.arg1 != c.brick ||
            es.arg1 != c.brick)
            return fail(ErrorCode::CorruptData, where + "section " + std::to_string(c.field_section) +
                                                    ": HT chunks out of order (expected cycle " +
                                                    std::to_string(c.cycle) + " brick " +
                                                    std::to_string(c.brick) + ")");
        if (L.residual_coding == kResidualZigzagPlanes) {
            if (fs.raw_size != c.points * W || es.raw_size != c.diamonds * 2)
                return fail(ErrorCode::CorruptData, where + "section " + std::to_string(c.field_section) +
                                                        ": raw size does not match the chunk's point count");
            continue;
        }
        // Coding 2 (spec §7.5): stored range-coder streams, never zstd; the
        // point count is bounded by the stream length before anything is allocated.
        // Coding 3 (§6.4): the same for range-mode chunks; the other modes'
        // sizes are fixed by the chunk's point count, checked here.
        for (const auto& [si, count] : {std::pair{c.field_section, c.points}, std::pair{c.error_section, c.diamonds}}) {
            const auto& s = secs[si];
            const std::string sec = where + "section " + std::to_string(si) + ": ";
            if (L.residual_coding == kResidualChunkModes) {
                if (auto bad = check_chunk_mode(s, count, si == c.field_section ? uint64_t(W) : 2,
                                                si == c.field_section, has_lattice))
                    return fail(bad->first, sec + bad->second);
                // Lattice, range-2d and range-exp streams are range-coder streams: the
                // same size rules (range-exp's base exponent byte only makes them stricter).
                const uint32_t mode = tlod::section_mode(s.flags);
                if (mode != kModeRange && mode != kModeLattice && mode != kModeRange2d && mode != kModeRangeExp)
                    continue;
            } else if (s.flags & tlod::kSectionModeMask) {
                return fail(ErrorCode::CorruptData, sec + "chunk mode bits set in a file of residual coding " +
                                                        std::to_string(L.residual_coding));
            }
            if (s.flags & tlod::kSectionZstd)
                return fail(ErrorCode::CorruptData, sec + "range-coded HT chunks must not be zstd-compressed");
            if ((count == 0) != (s.raw_size == 0) || (count > 0 && s.raw_size < 5))
                return fail(ErrorCode::CorruptData, sec + "coded size " + std::to_string(s.raw_size) +
                                                        " impossible for " + std::to_string(count) + " values");
            if (count > kMaxPointsPerByte * s.raw_size)
                return fail(ErrorCode::CorruptData, sec + std::to_string(count) + " values cannot fit in " +
                                                        std::to_string(s.raw_size) + " coded bytes");
        }
    }
    return L;
}

}  // namespace tetlod
