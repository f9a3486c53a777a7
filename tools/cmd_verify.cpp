// tetlod verify: every checksum and structural rule of a .tlod container;
// --deep also recomputes the exact diamond errors from the decoded field and
// checks that every stored bound is at least the recomputed error. An MT is
// decoded (labels, dependencies, errors and masks validated) and extracted; with
// --deep its full mesh must be the reference mesh, 5 tets per cell.
#include <CLI/CLI.hpp>

#include <ostream>

#include "cli_common.hpp"
#include "command.hpp"

namespace tetlod::cli {

namespace {

// Prints what the report established, in order; a failure ends the line where
// verification stopped and is then raised (exit status from its code).
int run_verify(const std::string& input, bool deep) {
    Stopwatch sw;
    const VerifyReport rep = verify_container(input, deep);
    auto& o = out();
    if (rep.checksums_ok)
        o << input << ": OK: header, table and " << rep.sections << " section checksums";
    if (rep.mt_ok)
        o << "; MT structure (" << rep.mt_updates << " vertex splits, " << rep.mt_tets_at_error0
          << " tets at error 0)";
    if (rep.mt_deep_ok) o << "; deep: MT full mesh = reference mesh (" << rep.mt_reference_tets << " tets)";
    if (rep.ht_ok) o << "; HT structure; field and " << rep.ht_chunks_decoded << " chunks decoded";
    if (rep.ht_deep_ok)
        o << "; deep: all " << rep.ht_bounds_checked << " stored bounds >= exact errors (at most "
          << format_number(rep.ht_worst_bound_ratio) << "x)";
    if (rep.failure) throw Error(rep.failure->code, rep.failure->message);
    o << " (" << format_seconds(sw.seconds()) << ")\n";
    return 0;
}

const CommandRegistration registration{Command{
    "verify", "Check every checksum and structural rule of a .tlod container", 22,
    [](CLI::App& sub) -> std::function<int()> {
        auto in = std::make_shared<std::string>();
        auto deep = std::make_shared<bool>(false);
        sub.add_option("input", *in, "Input .tlod file")->required();
        sub.add_flag("--deep", *deep,
                     "Also recompute every diamond error from the field and check the stored "
                     "bounds hold");
        sub.footer("Exit status: 0 valid, 4 invalid (the message names the problem), 3 I/O.\n"
                   "Examples:\n  tetlod verify neghip.tlod\n  tetlod verify neghip.tlod --deep");
        return [in, deep] { return run_verify(*in, *deep); };
    }}};

}  // namespace

}  // namespace tetlod::cli
