// What a container holds, read from its header, table and model headers only
// (see container.hpp).
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/container.hpp"

namespace tetlod {

namespace {

std::string lower_extension(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
    return e;
}

HtInfo ht_info(const HtLayout& lay, const std::vector<tlod::SectionInfo>& secs) {
    HtInfo h;
    const HtDomain& d = lay.domain;
    h.k = d.k;
    h.L = d.L;
    h.box_max = d.box_max;
    h.padded = d.padded;
    h.max_level = d.max_level();
    h.brick_log2 = lay.brick_log2;
    h.error_mantissa_bits = lay.error_mantissa_bits;
    for (const auto& s : secs)
        if (s.type == tlod::kSectionHtHeader || s.type == tlod::kSectionHtField || s.type == tlod::kSectionHtErrors)
            h.section_bytes += s.stored_size;
    std::map<int, HtCycleInfo, std::greater<int>> cycles;
    for (const HtChunk& c : lay.chunks) {
        auto& s = cycles[c.cycle];
        s.cycle = c.cycle;
        ++s.chunks;
        s.points += c.points;
        s.field_bytes += secs[c.field_section].stored_size;
        s.error_bytes += secs[c.error_section].stored_size;
        s.raw_bytes += secs[c.field_section].raw_size + secs[c.error_section].raw_size;
    }
    for (auto& [t, s] : cycles) {
        // Cycle t holds the centres of diamonds of levels 3(k-1-t) .. 3(k-1-t)+2.
        const int l0 = 3 * (d.k - 1 - t);
        s.levels = t == d.k ? "corners" : std::to_string(l0) + ".." + std::to_string(l0 + 2);
        h.cycles.push_back(s);
    }
    return h;
}

MtInfo mt_info(const MtLayout& lay, const std::vector<tlod::SectionInfo>& secs) {
    MtInfo m;
    m.base_tets = lay.base_tets;
    m.updates = lay.updates;
    m.error_mantissa_bits = lay.error_mantissa_bits;
    m.field_from_ht = lay.with_ht;
    m.header_bytes = secs[lay.header_section].stored_size;
    m.structure_bytes = secs[lay.structure_section].stored_size;
    for (const auto& s : secs)
        if (s.type == tlod::kSectionMtHeader || s.type == tlod::kSectionMtStructure) m.section_bytes += s.stored_size;
    return m;
}

}  // namespace

bool is_container_path(const std::string& path) {
    return is_tlod_file(path) || lower_extension(path) == ".tlod";
}

ContainerModels container_models(const std::string& path) {
    ContainerModels m;
    auto r = tlod::ContainerReader::open(path);
    if (!r) return m;
    m.ht = (r->header().required_features & tlod::kFeatureHt) != 0;
    m.mt = container_has_mt(*r);
    return m;
}

std::string ContainerInfo::format_key(const std::string& key) const {
    auto it = metadata.format_keys.find(key);
    return it == metadata.format_keys.end() ? std::string() : it->second;
}

Expected<ContainerInfo> inspect_container(const std::string& path) {
    auto r = tlod::ContainerReader::open(path);
    if (!r) return r.failure();
    ContainerInfo info;
    info.path = path;
    info.header = r->header();
    info.sections = r->sections();
    if (info.header.required_features & tlod::kFeatureHt) {
        auto l = read_ht_layout(*r);
        if (!l) return l.failure();
        info.ht = ht_info(*l, info.sections);
        info.metadata = l->metadata;
        info.ht_residual_coding = l->residual_coding;
        info.max_error = l->max_error;
    }
    if (container_has_mt(*r)) {
        auto l = read_mt_layout(*r);
        if (!l) return l.failure();
        info.mt = mt_info(*l, info.sections);
        if (!info.ht) info.metadata = l->metadata;
    }
    if (!info.ht && !info.mt) return fail(ErrorCode::NotFound, path + ": the container holds no model");
    info.coders = section_coders(info.sections, info.ht_residual_coding);
    info.bytes_read = r->bytes_read();
    return info;
}

}  // namespace tetlod
