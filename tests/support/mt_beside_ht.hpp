#pragma once
// Test helper, header-only: a container assembled from an HT-only container's
// stored sections (copied byte for byte) and a given MT encoded beside them, so
// tests can write MTs the converter never would (edited errors, a missing E).
#include <cstddef>
#include <string>

#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

namespace tetlod::test {

/// Writes `out`: the sections of `ht_only` plus `mt`, its update errors stored
/// with `field_error` added (the E of a LOSSY_MT file; 0 for a lossless one).
inline void write_mt_beside_ht(const std::string& ht_only, const MtModel& mt, double field_error,
                               const std::string& out) {
    auto r = tlod::ContainerReader::open(ht_only).take();
    tlod::ContainerWriter w;
    w.set_features(r.header().required_features & ~tlod::kFeatureCompactTable);
    for (std::size_t i = 0; i < r.sections().size(); ++i) {
        const tlod::SectionInfo s = r.sections()[i];
        w.add_stored(s.type, s.flags, s.arg0, s.arg1, r.read_stored(i).take(), s.raw_size);
    }
    MtEncodeOptions eo;
    eo.field_error = field_error;
    encode_mt_container(mt, tlod::metadata_for_volume(mt.field()), w, true, eo);
    w.write(out);
}

}  // namespace tetlod::test
