#include <cmath>
#include <string>

#include "lod_query_region.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::detail {

void check_query(const LodQuery& q) {
    if (q.box) {
        const auto& b = *q.box;
        for (int a = 0; a < 3; ++a)
            if (b[a] > b[a + 3])
                throw Error(ErrorCode::InvalidArgument,
                            "query box: lower corner exceeds the upper corner on axis " + std::string(1, "xyz"[a]));
    }
    for (double v : q.isovalues)
        if (!std::isfinite(v)) throw Error(ErrorCode::InvalidArgument, "isovalue must be finite");
    for (const auto& r : q.regions)
        if (!r) throw Error(ErrorCode::InvalidArgument, "query region is null");
    if (std::isnan(q.error_in) || std::isnan(q.error_out))
        throw Error(ErrorCode::InvalidArgument, "error bound is NaN");
}

}  // namespace tetlod::detail
