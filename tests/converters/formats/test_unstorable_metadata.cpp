// Each volume writer leaves out the metadata keys its syntax cannot hold
// (instead of refusing the whole volume), writes every other key, and lists
// exactly the keys it left out (metadata_keys_lost), for callers to report.
#include <gtest/gtest.h>

#include "format_test_util.hpp"
#include "tetlod/converters/volume_formats.hpp"

using namespace tetlod;
using namespace tetlod::test;

TEST(UnstorableMetadata, WritersLeaveOutAndListWhatTheyCannotHold) {
    const std::string dir = tmp_dir("unstorable_meta");
    Volume v = make_volume(ValueType::I16, {4, 3, 5});
    v.metadata.clear();
    v.metadata["plain"] = "kept everywhere";
    v.metadata["with space"] = "not a MetaImage key";
    v.metadata["a:=b"] = "not a NRRD key";
    v.metadata["Offset"] = "a MetaIO field";
    v.metadata[""] = "no key at all";
    struct Case {
        std::string file;
        std::vector<std::string> lost;  // in key order
    };
    std::vector<Case> cases = {{"v.mha", {"", "Offset", "a:=b", "with space"}},
                               {"v.mhd", {"", "Offset", "a:=b", "with space"}},
                               {"v.nrrd", {"", "a:=b"}},
                               {"v.nhdr", {"", "a:=b"}},
                               {"v_4x3x5_int16.raw", {"", "Offset", "a:=b", "plain", "with space"}}};
    if (volume_format_built("vdb")) cases.push_back({"v.vdb", {""}});
    if (volume_format_built("h5")) cases.push_back({"v.h5", {""}});
    for (const auto& c : cases) {
        SCOPED_TRACE(c.file);
        const std::string path = dir + "/" + c.file;
        EXPECT_EQ(metadata_keys_lost(v, path), c.lost);
        ASSERT_NO_THROW(write_volume(v, path));
        const Volume r = read_volume(path);
        expect_same_samples(v, r);
        if (c.file.ends_with(".raw")) continue;
        for (const auto& [k, val] : v.metadata) {
            const bool lost = std::find(c.lost.begin(), c.lost.end(), k) != c.lost.end();
            EXPECT_EQ(r.metadata.count(k), lost ? 0u : 1u) << "key '" << k << "'";
            if (!lost && r.metadata.count(k)) {
                EXPECT_EQ(r.metadata.at(k), val) << k;
            }
        }
    }
}
