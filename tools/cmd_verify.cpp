// tetlod verify: every checksum and structural rule of a .tlod container;
// --deep also recomputes, by brute force from the decoded field, the exact closed
// error of every HT tet in the data box and checks that its diamond's bound is at
// least that error plus E (lossy), and +inf where a tet crosses the box. An MT is
// decoded (labels, dependencies, errors and masks validated) and extracted; with
// --deep a full refinement must end at the reference mesh, 5 tets per cell, and
// every tet it passes through must have a closed error (recomputed exactly from
// the decoded field) at most its creator's stored error, minus E when lossy.
#include <CLI/CLI.hpp>

#include <ostream>

#include "cli_common.hpp"
#include "command.hpp"

namespace tetlod::cli {

namespace {

// Prints what the report established, in order; a failure ends the line where
// verification stopped and is then raised (exit status from its code).
struct VerifyArgs {
    std::string input, original;
    bool deep = false;
    VolumeFlags volume;  // of --original
};

int run_verify(const VerifyArgs& a) {
    const std::string& input = a.input;
    Stopwatch sw;
    const VerifyReport rep = verify_container(input, a.deep);
    auto& o = out();
    if (rep.checksums_ok)
        o << input << ": OK: header, table and " << rep.sections << " section checksums";
    if (rep.mt_ok)
        o << "; MT structure (" << rep.mt_updates << " vertex splits, " << rep.mt_tets_at_error0
          << " tets at error 0)";
    if (rep.mt_deep_ok) {
        o << "; deep: MT full mesh = reference mesh (" << rep.mt_reference_tets << " tets); all "
          << rep.mt_bounds_checked << " MT tet bounds >= exact errors (at most " << format_number(rep.mt_worst_bound_ratio)
          << "x)";
        if (rep.mt_bounds_unchecked > 0)
            o << " (" << rep.mt_bounds_unchecked << " tets with non-finite values not checked)";
    }
    if (rep.ht_ok) o << "; HT structure; field and " << rep.ht_chunks_decoded << " chunks decoded";
    if (rep.ht_deep_ok) {
        o << "; deep: all " << rep.ht_bounds_checked << " HT tet bounds >= exact errors (at most "
          << format_number(rep.ht_worst_bound_ratio) << "x)";
        if (rep.ht_bounds_unchecked > 0)
            o << " (" << rep.ht_bounds_unchecked << " tets with non-finite values not checked)";
    }
    if (rep.ht_ok && rep.max_error > 0)
        o << "; lossy: every sample within " << format_max_error(rep.max_error) << " of the original (stated)";
    if (rep.failure) throw Error(rep.failure->code, rep.failure->message);
    if (!a.original.empty() && rep.has_ht) {
        // The statement itself, against the original volume given.
        auto planes = open_volume_planes(a.original, a.volume.options());
        const OriginalCheck c = check_against_original(input, *planes);
        if (!c.ok()) {
            o << "\n";
            throw Error(ErrorCode::CorruptData,
                        input + ": " + std::to_string(c.beyond) + " of " + std::to_string(c.samples) +
                            " samples are " + (c.max_error > 0 ? "farther than " + format_max_error(c.max_error) + " from"
                                                                : "not bit-identical to") +
                            " the original " + a.original + " (first at (" + std::to_string(c.first_beyond[0]) + "," +
                            std::to_string(c.first_beyond[1]) + "," + std::to_string(c.first_beyond[2]) +
                            "), largest deviation " + format_number(c.max_deviation) + ")");
        }
        o << "; original: all " << c.samples << " samples "
          << (c.max_error > 0 ? "within " + format_max_error(c.max_error) + " (largest " + format_number(c.max_deviation) + ")"
                              : std::string("bit-identical"));
    }
    o << " (" << format_seconds(sw.seconds()) << ")\n";
    return 0;
}

const CommandRegistration verify_registration{Command{
    "verify", "Check every checksum and structural rule of a .tlod container", 22,
    [](CLI::App& sub) -> std::function<int()> {
        auto a = std::make_shared<VerifyArgs>();
        sub.add_option("input", a->input, "Input .tlod file")->required();
        sub.add_flag("--deep", a->deep,
                     "Also recompute the exact errors from the field and check the stored bounds "
                     "hold (plus E when lossy): for the HT, every tet of the hierarchy in the data box "
                     "against its diamond's bound; for the MT, every tet of a full refinement against "
                     "its creator's update error");
        sub.add_option("--original", a->original,
                       "The original volume: check every stored sample is within the container's "
                       "stated bound of it (lossy: E; lossless: bit-identical)");
        add_volume_flags(sub, a->volume);
        sub.footer("Exit status: 0 valid, 4 invalid (the message names the problem), 3 I/O.\n"
                   "Examples:\n  tetlod verify neghip.tlod\n  tetlod verify neghip.tlod --deep\n"
                   "  tetlod verify neghip_lossy.tlod --deep --original neghip_64x64x64_uint8.raw");
        return [a] { return run_verify(*a); };
    }}};

}  // namespace

}  // namespace tetlod::cli
