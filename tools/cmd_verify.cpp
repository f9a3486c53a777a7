// tetlod verify: every checksum and structural rule of a .tlod container;
// --deep also recomputes the exact diamond errors from the decoded field and
// checks that every stored bound is at least the recomputed error. An MT is
// decoded (labels, dependencies, errors and masks validated) and extracted; with
// --deep its full mesh must be the reference mesh, 5 tets per cell.
#include <CLI/CLI.hpp>

#include <cmath>
#include <ostream>

#include "cli_common.hpp"
#include "command.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::cli {

namespace {

int run_verify(const std::string& input, bool deep) {
    Stopwatch sw;
    auto r = tlod::ContainerReader::open(input);
    if (!r) throw Error(r.failure().code, r.failure().message);
    // Checksums of every section, known or not.
    for (std::size_t i = 0; i < r->sections().size(); ++i) {
        auto s = r->read_stored(i);
        if (!s) throw Error(s.failure().code, s.failure().message);
    }
    auto& o = out();
    o << input << ": OK: header, table and " << r->sections().size() << " section checksums";
    const bool has_ht = (r->header().required_features & tlod::kFeatureHt) != 0;
    const bool has_mt = container_has_mt(*r);
    if (!has_ht && !has_mt) throw Error(ErrorCode::NotFound, input + ": the container holds no model");
    if (has_mt) {
        auto r2 = tlod::ContainerReader::open(input);
        if (!r2) throw Error(r2.failure().code, r2.failure().message);
        auto mt = decode_mt_container(*r2);
        if (!mt) throw Error(mt.failure().code, mt.failure().message);
        LodQuery q;
        q.error_in = 0.0;
        const TetMesh m0 = mt->extract(q);  // throws CorruptData on an inconsistent MT
        o << "; MT structure (" << mt->updates().size() << " vertex splits, " << m0.tet_count()
          << " tets at error 0)";
        if (deep) {
            LodQuery full;
            full.full = true;
            const Dims dd = mt->field().dims;
            const uint64_t want = 5 * uint64_t(dd.x - 1) * uint64_t(dd.y - 1) * uint64_t(dd.z - 1);
            const uint64_t got = mt->extract(full).tet_count();
            if (got != want)
                throw Error(ErrorCode::CorruptData, input + ": the MT's full mesh has " + std::to_string(got) +
                                                        " tets, the reference mesh " + std::to_string(want));
            o << "; deep: MT full mesh = reference mesh (" << want << " tets)";
        }
    }
    if (!has_ht) {
        o << " (" << format_seconds(sw.seconds()) << ")\n";
        return 0;
    }
    // Structure, frames, sizes and code ranges: decode everything.
    auto d = decode_ht(*r);
    if (!d) throw Error(d.failure().code, d.failure().message);
    o << "; HT structure; field and " << d->chunks_decoded << " chunks decoded";
    if (deep) {
        HtBuildOptions bo;
        bo.pad = d->layout.domain.padded;
        Volume v;
        if (d->layout.domain.padded) {
            auto r2 = tlod::ContainerReader::open(input);
            auto orig = decode_volume(*r2);
            if (!orig) throw Error(orig.failure().code, orig.failure().message);
            v = std::move(*orig);
        } else {
            v = d->field;
        }
        const HtModel m = HtModel::build(std::move(v), bo);
        const auto& truth = m.diamond_errors();
        if (truth.size() != d->errors.size())
            throw Error(ErrorCode::CorruptData, input + ": recomputed model has a different size");
        uint64_t bad = 0, first = 0;
        double worst_ratio = 1.0;
        for (std::size_t i = 0; i < truth.size(); ++i) {
            const float t = truth[i], s = d->errors[i];
            if (!(s >= t) && !std::isnan(t)) {
                if (bad++ == 0) first = i;
            } else if (t > 0 && std::isfinite(s)) {
                worst_ratio = std::max(worst_ratio, double(s) / double(t));
            }
        }
        if (bad) {
            const Dims dd = d->field.dims;
            throw Error(ErrorCode::CorruptData,
                        input + ": " + std::to_string(bad) +
                            " stored error bounds are below the recomputed errors (first at (" +
                            std::to_string(first % dd.x) + "," + std::to_string(first / dd.x % dd.y) +
                            "," + std::to_string(first / (dd.x * dd.y)) + "): stored " +
                            format_number(d->errors[first]) + ", exact " +
                            format_number(truth[first]) + ")");
        }
        o << "; deep: all " << truth.size() << " stored bounds >= exact errors (at most "
          << format_number(worst_ratio) << "x)";
    }
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
