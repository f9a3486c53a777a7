// Exact per-diamond errors of a whole in-memory field (spec/tlod-format.md §2
// "Diamond error"; docs/ht.md "Errors"): every level, one visit per grid point
// per level. The evaluators are in ht_error_builder.hpp; ht_error_sweep.cpp
// runs them slab by slab for volumes that do not fit in memory.
#include "ht_error_build.hpp"

#include "ht_error_builder.hpp"

namespace tetlod::ht {
namespace {

using namespace error_detail;

template <class T, class Acc>
void run_all_levels(const ErrorBuilder<T, Acc>& eb, ZeroedVector<float>& out, double slack) {
    const HtDomain& d = eb.domain();
    for (int level = 0; level < d.max_level(); ++level) {
        const auto lt = eb.level_templates(level);
        eb.for_level_rows(level, 0, d.box_max[2], [&](int32_t x0, int32_t y, int32_t z, int32_t step, int32_t x1) {
            float* row = &out[std::size_t(eb.index(Pt{0, y, z}))];
            eb.errors_along_row(lt, x0, y, z, step, x1, [&](int32_t x, double err) { row[x] = eb.round_up(err, slack); });
        });
    }
}

}  // namespace

ZeroedVector<float> compute_diamond_errors(const Volume& field, const HtDomain& domain) {
    ZeroedVector<float> errors(static_cast<std::size_t>(field.count()));  // zeros, not walked
    dispatch_value_type(field.type, [&](auto tag) {
        using T = decltype(tag);
        with_accumulator<T>(domain, field.range(), [&](auto acc, double slack) {
            using Acc = decltype(acc);
            const ErrorBuilder<T, Acc> eb(field.as<T>(), 0, field.dims.x, field.dims.x * field.dims.y, domain);
            run_all_levels(eb, errors, slack);
        });
    });
    return errors;
}

}  // namespace tetlod::ht
