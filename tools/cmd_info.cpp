// tetlod info: what a .tlod container holds, reading only its header, section
// table, METADATA and HT_HEADER (fast on a multi-GB file).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <map>
#include <optional>
#include <nlohmann/json.hpp>
#include <ostream>

#include "cli_common.hpp"
#include "cli_outputs.hpp"
#include "command.hpp"

namespace tetlod::cli {

namespace {

struct InfoArgs {
    std::string input;
    bool json = false;
    bool sections = false;
};

int run_info(const InfoArgs& a) {
    const ContainerInfo info = inspect_container(a.input).take();
    const tlod::Header& h = info.header;
    const std::optional<HtInfo>& lay = info.ht;
    const std::optional<MtInfo>& mlay = info.mt;
    const tlod::Metadata& md = info.metadata;
    const auto& secs = info.sections;
    const double n = double(md.dims.count());
    const uint64_t ht_bytes = lay ? lay->section_bytes : 0, mt_bytes = mlay ? mlay->section_bytes : 0;
    auto key = [&](const char* k) { return info.format_key(k); };
    // Header and table end where the first section starts (spec §3), whatever the layout.
    const uint64_t framing = secs.empty() ? h.file_size : secs.front().offset;
    const char* table_layout = tlod::table_layout_name((h.required_features & tlod::kFeatureCompactTable)
                                                           ? tlod::TableLayout::compact
                                                           : tlod::TableLayout::full);

    if (a.json) {
        nlohmann::json j;
        j["file"] = a.input;
        j["file_size"] = h.file_size;
        j["format_version"] = std::to_string(h.version_major) + "." + std::to_string(h.version_minor);
        j["required_features"] = h.required_features;
        j["optional_features"] = h.optional_features;
        j["dims"] = {md.dims.x, md.dims.y, md.dims.z};
        j["value_type"] = value_type_name(md.type);
        j["spacing"] = md.spacing;
        j["origin"] = md.origin;
        j["value_range"] = md.value_range;
        // Format 3.1: whether the stored field is the original, and how close it is.
        j["field_mode"] = info.max_error > 0 ? "lossy" : "lossless";
        j["max_error"] = info.max_error;
        j["format_keys"] = md.format_keys;
        j["user_keys"] = md.user_keys;
        j["bytes_per_grid_point"] = double(h.file_size) / n;
        j["models"] = nlohmann::json::array();
        if (lay) {
            const auto& d = *lay;
            nlohmann::json m;
            m["type"] = "HT";
            m["k"] = d.k;
            m["L"] = d.L;
            m["box_max"] = d.box_max;
            m["padded"] = d.padded;
            m["levels"] = {0, d.max_level};
            m["brick_log2"] = lay->brick_log2;
            m["error_mantissa_bits"] = lay->error_mantissa_bits;
            m["error_max"] = key(tlod::kKeyHtErrorMax);
            m["always_split_diamonds"] = key(tlod::kKeyHtAlwaysSplit);
            m["section_bytes"] = ht_bytes;
            m["bytes_per_grid_point"] = double(ht_bytes) / n;
            for (const auto& s : lay->cycles)
                m["cycles"].push_back({{"cycle", s.cycle}, {"levels", s.levels}, {"chunks", s.chunks},
                                       {"points", s.points}, {"field_bytes", s.field_bytes},
                                       {"error_bytes", s.error_bytes}, {"raw_bytes", s.raw_bytes}});
            j["models"].push_back(m);
        }
        if (mlay) {
            nlohmann::json m;
            m["type"] = "MT";
            m["base_tets"] = mlay->base_tets;
            m["updates"] = mlay->updates;
            m["error_mantissa_bits"] = mlay->error_mantissa_bits;
            m["field"] = mlay->field_from_ht ? "shared with the HT" : "in the MT payload";
            m["header_bytes"] = mlay->header_bytes;
            m["structure_bytes"] = mlay->structure_bytes;
            m["section_bytes"] = mt_bytes;
            m["bytes_per_grid_point"] = double(mt_bytes) / n;
            j["models"].push_back(m);
        }
        for (std::size_t i = 0; i < secs.size(); ++i) {
            const auto& s = secs[i];
            j["sections"].push_back({{"index", i}, {"type", tlod::section_type_name(s.type)},
                                     {"type_id", s.type}, {"flags", s.flags}, {"offset", s.offset},
                                     {"stored_size", s.stored_size}, {"raw_size", s.raw_size},
                                     {"arg0", s.arg0}, {"arg1", s.arg1},
                                     {"coder", section_coder(s, info.ht_residual_coding)}});
            const std::string mode = section_mode_name(s, info.ht_residual_coding);
            if (!mode.empty()) j["sections"].back()["mode"] = mode;
        }
        // Issue 13: which coder each kind of section uses and what it costs.
        j["coders"] = nlohmann::json::array();
        for (const auto& c : info.coders)
            j["coders"].push_back({{"section", c.section}, {"type_id", c.type}, {"coder", c.coder},
                                   {"description", c.description}, {"count", c.count},
                                   {"empty", c.empty}, {"stored_bytes", c.stored_bytes},
                                   {"raw_bytes", c.raw_bytes},
                                   {"share", double(c.stored_bytes) / double(h.file_size)}});
        // Format 3.0: one row per chunk mode of each section kind, with its bytes.
        for (std::size_t i = 0; i < info.coders.size(); ++i)
            if (!info.coders[i].mode.empty()) j["coders"][i]["mode"] = info.coders[i].mode;
        j["framing_bytes"] = framing;
        // Format 3.2: the section table's layout and its bytes (framing less the header).
        j["table_layout"] = table_layout;
        j["table_bytes"] = framing - tlod::kHeaderSize;
        j["bytes_read"] = info.bytes_read;
        // User metadata values are arbitrary bytes (spec): never fail on them.
        out() << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
        return 0;
    }
    auto& o = out();
    o << with_stdin_named(a.input) << ": tlod " << h.version_major << "." << h.version_minor << ", "
      << format_bytes(h.file_size) << " (" << format_number(double(h.file_size) / n)
      << " bytes per grid point; raw " << value_size(md.type) << ")\n";
    o << "  models    " << (lay ? "HT " + format_bytes(ht_bytes) + " (" + format_number(double(ht_bytes) / n) + " B/pt)" : "")
      << (lay && mlay ? ", " : "")
      << (mlay ? "MT " + format_bytes(mt_bytes) + " (" + format_number(double(mt_bytes) / n) + " B/pt)" : "") << "\n";
    o << "  volume    " << format_dims(md.dims) << " " << value_type_name(md.type) << ", field '"
      << md.field_name() << "'" << (md.units().empty() ? "" : " [" + md.units() + "]") << ", values "
      << format_number(md.value_range[0]) << ".." << format_number(md.value_range[1]) << "\n";
    if (info.max_error > 0)
        o << "  field     lossy: every sample within " << format_max_error(info.max_error)
          << " of the original; error bounds include it\n";
    else
        o << "  field     lossless\n";
    o << "  geometry  spacing " << format_number(md.spacing[0]) << "," << format_number(md.spacing[1])
      << "," << format_number(md.spacing[2]) << "  origin " << format_number(md.origin[0]) << ","
      << format_number(md.origin[1]) << "," << format_number(md.origin[2]) << "\n";
    if (lay) {
        const auto& d = *lay;
        o << "  model     HT, k = " << d.k << " (cube " << d.L + 1 << "^3), levels 0.." << d.max_level
          << ", box " << d.box_max[0] + 1 << "x" << d.box_max[1] + 1 << "x" << d.box_max[2] + 1
          << (d.padded ? " (padded)" : "") << ", bricks 2^(t+" << lay->brick_log2 + 1 << ")\n";
        o << "  errors    per diamond, rounded up to " << lay->error_mantissa_bits
          << " mantissa bits; max finite " << key(tlod::kKeyHtErrorMax) << ", always split "
          << key(tlod::kKeyHtAlwaysSplit)
          << (info.max_error > 0 ? " (of the stored field; + " + format_max_error(info.max_error) + " against the original)"
                                 : std::string())
          << "\n";
    }
    if (mlay)
        o << "  model     MT, " << mlay->updates << " vertex splits on " << mlay->base_tets
          << " base tets, errors rounded up to " << mlay->error_mantissa_bits << " mantissa bits"
          << (info.max_error > 0 ? " (against the original: they include the field's " + format_max_error(info.max_error) + ")"
                                 : std::string())
          << ", field "
          << (mlay->field_from_ht ? "shared with the HT" : "in the MT payload") << "; MT_HEADER "
          << mlay->header_bytes << " B, MT_STRUCTURE " << mlay->structure_bytes << " B\n";
    for (const auto& [k, v] : md.format_keys)
        if (k.rfind("ht.", 0) != 0 && k != tlod::kKeyFieldName && k != tlod::kKeyFieldUnits)
            o << "  " << k << std::string(k.size() < 12 ? 12 - k.size() : 1, ' ') << v << "\n";
    for (const auto& [k, v] : md.user_keys) o << "  user: " << k << " = " << v << "\n";
    if (lay) {
        o << "  cycle  levels    chunks     points   field bytes  error bytes   B/pt (of all)\n";
        for (const auto& s : lay->cycles) {
            char line[160];
            std::snprintf(line, sizeof line, "  %5d  %-8s %7llu %10llu %13llu %12llu   %.3f\n", s.cycle,
                          s.levels.c_str(), (unsigned long long)s.chunks,
                          (unsigned long long)s.points, (unsigned long long)s.field_bytes,
                          (unsigned long long)s.error_bytes,
                          double(s.field_bytes + s.error_bytes) / n);
            o << line;
        }
    }
    // Where the bytes go: one row per section type and coder (header and table
    // are the rest of the file).
    o << "  sections      coder               count  empty   stored bytes      raw bytes  of file\n";
    for (const auto& c : info.coders) {
        char line[200];
        std::snprintf(line, sizeof line, "  %-12s  %-18s %6llu %6llu %14llu %14llu  %5.1f%%\n",
                      c.section.c_str(), c.coder.c_str(), (unsigned long long)c.count,
                      (unsigned long long)c.empty, (unsigned long long)c.stored_bytes,
                      (unsigned long long)c.raw_bytes, 100.0 * double(c.stored_bytes) / double(h.file_size));
        o << line;
    }
    o << "  header+table  " << framing << " bytes (" << table_layout << " section table, "
      << framing - tlod::kHeaderSize << " bytes for " << secs.size() << " sections)\n";
    if (a.sections) {
        o << "  section  type          flags      offset     stored        raw  arg0  arg1  coder\n";
        for (std::size_t i = 0; i < secs.size(); ++i) {
            const auto& s = secs[i];
            char line[160];
            std::snprintf(line, sizeof line, "  %7zu  %-12s  0x%02x %11llu %10llu %10llu %5u %5u  %s\n", i,
                          tlod::section_type_name(s.type), s.flags, (unsigned long long)s.offset,
                          (unsigned long long)s.stored_size, (unsigned long long)s.raw_size, s.arg0,
                          s.arg1, section_coder(s, info.ht_residual_coding).c_str());
            o << line;
        }
    }
    detail("read " + std::to_string(info.bytes_read) + " bytes of the file");
    return 0;
}

const CommandRegistration info_registration{Command{
    "info", "Describe a .tlod container (reads only its metadata)", 21,
    [](CLI::App& sub) -> std::function<int()> {
        auto a = std::make_shared<InfoArgs>();
        sub.add_option("input", a->input, "Input .tlod file")->required();
        sub.add_flag("--json", a->json, "Machine-readable output (every section listed)");
        sub.add_flag("--sections", a->sections, "List every section in the text output");
        sub.footer("Examples:\n  tetlod info neghip.tlod\n  tetlod info neghip.tlod --json");
        return [a] { return run_info(*a); };
    }}};

}  // namespace

}  // namespace tetlod::cli
