// Which coder each section of a container uses, and its bytes (see
// container.hpp, SectionCoderInfo). Reads nothing: the section table and the
// HT_HEADER already say it all.
#include <algorithm>
#include <iterator>

#include "tetlod/container.hpp"

namespace tetlod {

namespace {

bool zstd_flagged(const tlod::SectionInfo& s) { return (s.flags & tlod::kSectionZstd) != 0; }

std::string describe(const std::string& coder, uint32_t type) {
    if (coder == "stored") return "raw bytes, no compression";
    if (coder == "zstd") return "one zstd frame (§4.2; the level is not recorded)";
    if (coder == "mt-zstd-payload")
        return "the MT's streams in zstd: coding 3, 12 streams (errors in label order), or coding 2, 11 streams, "
               "a frame each; coding 1, 7 in one (§10.2)";
    if (coder == "unknown") return "unknown section type (skipped)";
    const bool field = type == tlod::kSectionHtField;
    if (coder == "ht-constant") return "every value of the chunk equal: one value (§6.4)";
    if (coder == "ht-samples+zstd") return "the chunk's values in point order, one zstd frame (§6.4)";
    if (coder == "ht-samples") return "the chunk's values in point order, uncompressed (§6.4)";
    if (coder == "ht-zero-residual") return "every value equals its prediction: no bytes (§6.4)";
    if (coder == "ht-lattice") return "multiples of the lossy step: their indices range coded (§6.4)";
    if (coder == "ht-static-rans")
        return "neighbour prediction, one symbol a point from the chunk's static tables, rANS (§6.4, §7.6)";
    if (coder == "ht-range-exp")
        return "error codes against the lattice bound, adaptive range coder, contexts from the bound's exponent (§6.4, §8.4)";
    if (coder == "ht-range-2d")
        return "neighbour prediction, adaptive range coder, spread and neighbour contexts apart (§6.4, §7.6)";
    if (coder == "ht-range-v2")
        return field ? "neighbour prediction, adaptive range coder (§7.4-7.6)"
                     : "lattice-bound prediction, adaptive range coder (§8.3)";
    const std::string planes = field ? "coarse-mean prediction, zigzag byte planes (§7.2-7.3)"
                                     : "spine prediction, byte planes (§8.2)";
    return coder == "ht-planes-v1+zstd" ? planes + " in a zstd frame" : planes;
}

}  // namespace

std::string section_coder(const tlod::SectionInfo& s, int ht_residual_coding) {
    switch (s.type) {
        case tlod::kSectionHtField:
        case tlod::kSectionHtErrors:
            // Coding 2 forbids the ZSTD flag (§4.3), so the flag only matters for 1.
            if (ht_residual_coding == 2) return "ht-range-v2";
            // Coding 3: the chunk mode in the table flags (§6.4); range is coding 2's coder.
            if (ht_residual_coding == 3) {
                switch (tlod::section_mode(s.flags)) {
                    case 0: return "ht-range-v2";
                    case 1: return "ht-constant";
                    case 2: return zstd_flagged(s) ? "ht-samples+zstd" : "ht-samples";
                    case 3: return "ht-zero-residual";
                    case 4: return "ht-lattice";
                    case 5: return "ht-range-2d";
                    case 6: return "ht-static-rans";
                    case 7: return "ht-range-exp";
                    default: return "unknown";
                }
            }
            return zstd_flagged(s) ? "ht-planes-v1+zstd" : "ht-planes-v1";
        case tlod::kSectionMtStructure:
            // Never flagged ZSTD: the frame is part of the MT's own encoding.
            return "mt-zstd-payload";
        case tlod::kSectionMetadata:
        case tlod::kSectionHtHeader:
        case tlod::kSectionMtHeader:
            return zstd_flagged(s) ? "zstd" : "stored";
        default:
            return "unknown";
    }
}

std::string section_mode_name(const tlod::SectionInfo& s, int ht_residual_coding) {
    if (ht_residual_coding != 3 || (s.type != tlod::kSectionHtField && s.type != tlod::kSectionHtErrors)) return "";
    static const char* const names[] = {"range",   "constant", "samples", "zero-residual",
                                        "lattice", "range-2d", "static",  "range-exp"};
    const uint32_t m = tlod::section_mode(s.flags);
    return m < std::size(names) ? names[m] : "unknown";
}

std::vector<SectionCoderInfo> section_coders(const std::vector<tlod::SectionInfo>& sections,
                                             int ht_residual_coding) {
    std::vector<SectionCoderInfo> rows;
    for (const auto& s : sections) {
        const std::string coder = section_coder(s, ht_residual_coding);
        auto it = std::find_if(rows.begin(), rows.end(),
                               [&](const SectionCoderInfo& r) { return r.type == s.type && r.coder == coder; });
        if (it == rows.end()) {
            // A new coder of a known type goes after that type's rows, so the
            // modes of one section kind are listed together.
            auto after = std::find_if(rows.rbegin(), rows.rend(), [&](const SectionCoderInfo& r) { return r.type == s.type; });
            SectionCoderInfo r;
            r.type = s.type;
            r.section = tlod::section_type_name(s.type);
            r.coder = coder;
            r.description = describe(coder, s.type);
            r.mode = section_mode_name(s, ht_residual_coding);
            it = rows.insert(after == rows.rend() ? rows.end() : after.base(), r);
        }
        ++it->count;
        // Zero-residual chunks have no bytes but are not empty.
        if (s.stored_size == 0 && it->mode != "zero-residual") ++it->empty;
        it->stored_bytes += s.stored_size;
        it->raw_bytes += s.raw_size;
    }
    return rows;
}

}  // namespace tetlod
