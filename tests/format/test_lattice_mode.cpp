// Format 3.3 chunk mode 4, lattice (spec/tlod-format.md §6.4): lossy fields
// on the step's lattice through the mode bit-exact for every value type,
// forced and chosen, the same bytes for any thread count; NaN, infinities,
// -0, denormals and huge values either coded exactly or left to other modes;
// the lattice's values checked against the spec's formulas computed here;
// hostile lattice sections refused with specific errors, never a crash.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/lossy_field.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tlod_test_util.hpp"

using namespace tetlod;
using namespace tetlod::tlod;

namespace {

constexpr uint32_t kLattice = 4;

/// A field within E of a noisy volume, every sample on the lattice where the
/// quantizer could put it (the lossy writer's lattice candidate).
Volume lattice_field(Dims d, ValueType t, double e, bool specials = false) {
    Volume v = tlodtest::make_volume(d, t, 5, specials);
    quantize_volume(v, e);
    return v;
}

std::vector<std::byte> encode(const Volume& v, double stated_e, int mode, int threads = 1) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    HtEncodeOptions eo;
    eo.brick_log2 = 1;
    eo.chunk_mode = mode;
    eo.max_error = stated_e;
    ContainerWriter w;
    encode_ht(HtModel::build(v), metadata_for_volume(v), w, eo);
    return w.finish();
}

/// Error sections in range-exp (format 3.8): the version says 3.8 with any.
int range_exp_sections_in(std::span<const std::byte> f) {
    auto r = ContainerReader::from_memory(f);
    int n = 0;
    for (const auto& s : r->sections()) n += s.type == kSectionHtErrors && section_mode(s.flags) == 7;
    return n;
}

int field_sections_in(std::span<const std::byte> f, uint32_t mode) {
    auto r = ContainerReader::from_memory(f);
    int n = 0;
    for (const auto& s : r->sections()) n += s.type == kSectionHtField && section_mode(s.flags) == mode;
    return n;
}

/// The spec's lattice value of a sample computed here from §6.4's formulas
/// (binary64 division rounded to nearest even, the product rounded to the type).
template <class T>
bool on_spec_lattice(T x, double s) {
    if constexpr (std::is_floating_point_v<T>) {
        double q = std::nearbyint(double(x) / s);
        if (std::isnan(q)) q = 0;
        q = std::clamp(q, -4503599627370496.0, 4503599627370496.0);
        const T back = q == 0 ? T(0) : T(q * s);
        return std::memcmp(&back, &x, sizeof(T)) == 0;
    } else {
        const int64_t si = int64_t(s);
        return int64_t(x) % si == 0;
    }
}

class LatticeMode : public ::testing::TestWithParam<ValueType> {};

}  // namespace

TEST_P(LatticeMode, ForcedAndChosenBitExact) {
    const ValueType t = GetParam();
    const Dims d{13, 11, 9};
    for (double e : {0.5, 3.0, 17.25}) {
        const double stated = stored_max_error(t, e);
        if (!(stated > 0)) continue;  // integers below 1: lossless
        const Volume v = lattice_field(d, t, e);
        for (int mode : {-1, int(kLattice)}) {
            SCOPED_TRACE(std::string(value_type_name(t)) + " E=" + std::to_string(e) + " mode " + std::to_string(mode));
            const auto bytes = encode(v, stated, mode, 1);
            ASSERT_TRUE(bytes == encode(v, stated, mode, 2)) << "bytes differ with 2 threads";
            auto r = ContainerReader::from_memory(bytes);
            ASSERT_TRUE(r.ok()) << r.failure().message;
            auto dec = decode_ht(*r);
            ASSERT_TRUE(dec.ok()) << dec.failure().message;
            ASSERT_EQ(dec->field.data, v.data);
            const int lattice = field_sections_in(bytes, kLattice);
            if (mode == int(kLattice)) EXPECT_GT(lattice, 0);
            // The version says 3.3 exactly when a section uses the mode (3.6, which
            // includes it, when a field chunk is range-2d; 3.8 with a range-exp error chunk).
            EXPECT_EQ(r->header().version_minor, range_exp_sections_in(bytes) > 0    ? 8
                                                 : field_sections_in(bytes, 5) > 0 ? 6
                                                 : lattice > 0                     ? 3
                                                                                   : 2);
            if (lattice > 0) {  // every value of the field is on the spec's lattice here
                const double s = is_float(t) ? 2 * stated : 2 * stated + 1;
                dispatch_value_type(t, [&](auto tv) {
                    using T = decltype(tv);
                    for (int64_t i = 0; i < v.count(); ++i)
                        ASSERT_TRUE(on_spec_lattice<T>(v.as<T>()[i], s)) << i;
                });
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, LatticeMode,
                         ::testing::Values(ValueType::U8, ValueType::I8, ValueType::U16, ValueType::I16,
                                           ValueType::U32, ValueType::I32, ValueType::F32, ValueType::F64));

TEST(LatticeModeChoice, FloatsPreferItAndNeverGrow) {
    for (ValueType t : {ValueType::F32, ValueType::F64}) {
        const Volume v = lattice_field({33, 33, 17}, t, 0.5);
        const auto chosen = encode(v, 0.5, -1), range = encode(v, 0.5, 0);
        EXPECT_GT(field_sections_in(chosen, kLattice), 0) << value_type_name(t);
        EXPECT_LT(chosen.size(), range.size()) << value_type_name(t);
    }
}

TEST(LatticeModeChoice, NeverInALosslessFile) {
    const Volume v = lattice_field({13, 11, 9}, ValueType::F32, 0.5);
    for (int mode : {-1, int(kLattice)}) {
        const auto bytes = encode(v, 0, mode);
        EXPECT_EQ(field_sections_in(bytes, kLattice), 0);
        EXPECT_EQ(ContainerReader::from_memory(bytes)->header().version_minor,
                  range_exp_sections_in(bytes) > 0 ? 8 : field_sections_in(bytes, 5) > 0 ? 6 : 2);
    }
}

/// -0, denormals, the extremes of the type and values far beyond the step
/// (NaN and infinities never reach an HT: HtModel::build refuses them): a
/// chunk holding one is coded in the lattice mode only when the value comes
/// back bit for bit, so the field always does.
TEST(LatticeModeSpecials, HugeTinyAndNegativeZeroRoundTripOrAvoidTheMode) {
    for (ValueType t : {ValueType::F32, ValueType::F64}) {
        for (double e : {0.5, 1e-30, 1e30, 1e300}) {
            if (t == ValueType::F32 && e == 1e300) continue;
            SCOPED_TRACE(std::string(value_type_name(t)) + " E=" + std::to_string(e));
            Volume v = lattice_field({11, 9, 7}, t, e);
            int on = 0;
            dispatch_value_type(t, [&](auto tv) {
                using T = decltype(tv);
                T* p = v.as<T>();
                p[1] = -T(0);
                p[4] = std::numeric_limits<T>::denorm_min();
                p[5] = std::numeric_limits<T>::lowest();
                p[40] = std::numeric_limits<T>::max();
                p[41] = T(e * 1e6);
                p[42] = T(-e * 3);
                p[v.count() - 1] = T(std::min(e * 4503599627370496.0 * 4, double(std::numeric_limits<T>::max()) / 2));
                for (int64_t i = 0; i < v.count(); ++i) on += on_spec_lattice<T>(p[i], 2 * e);
            });
            EXPECT_LT(on, v.count());  // some samples off the lattice
            for (int mode : {-1, int(kLattice)}) {
                const auto bytes = encode(v, e, mode);
                auto r = ContainerReader::from_memory(bytes);
                ASSERT_TRUE(r.ok());
                auto dec = decode_ht(*r);
                ASSERT_TRUE(dec.ok()) << dec.failure().message;
                ASSERT_EQ(dec->field.data, v.data) << "mode " << mode;
            }
        }
    }
}

// ---- hostile lattice sections ----
namespace {

struct Section {
    SectionInfo info;
    std::vector<std::byte> bytes;
};

struct File {
    uint64_t features = 0;
    std::vector<Section> sections;
};

File split(std::span<const std::byte> f) {
    auto r = ContainerReader::from_memory(f);
    File out{r->header().required_features & ~kFeatureCompactTable, {}};
    for (std::size_t i = 0; i < r->sections().size(); ++i)
        out.sections.push_back({r->sections()[i], *r->read_stored(i)});
    return out;
}

std::vector<std::byte> join(const File& f) {
    ContainerWriter w;
    w.set_features(f.features);
    for (const auto& s : f.sections)
        w.add_stored(s.info.type, s.info.flags, s.info.arg0, s.info.arg1, s.bytes, s.info.raw_size);
    return w.finish();
}

Failure decode_failure(const File& f) {
    const auto bytes = join(f);
    auto r = ContainerReader::from_memory(bytes);
    if (!r) return r.failure();
    auto d = decode_ht(*r);
    return d ? Failure{ErrorCode::Ok, {}} : d.failure();
}

std::size_t first_lattice(const File& f) {
    for (std::size_t i = 0; i < f.sections.size(); ++i)
        if (f.sections[i].info.type == kSectionHtField && section_mode(f.sections[i].info.flags) == kLattice)
            return i;
    ADD_FAILURE() << "no lattice section";
    return 0;
}

void expect(const File& f, ErrorCode code, const std::string& text) {
    const Failure got = decode_failure(f);
    EXPECT_EQ(got.code, code) << got.message;
    EXPECT_NE(got.message.find(text), std::string::npos) << got.message;
}

/// Replaces the METADATA's field.max_error (erased when `e` is empty).
void set_max_error(File& f, const std::string& e) {
    for (auto& s : f.sections)
        if (s.info.type == kSectionMetadata) {
            std::vector<std::byte> raw = s.bytes;
            if (s.info.flags & kSectionZstd) raw = zstd_decompress(s.bytes, s.info.raw_size).take();
            Metadata md = parse_metadata(raw).take();
            if (e.empty()) md.format_keys.erase(kKeyFieldMaxError);
            else md.format_keys[kKeyFieldMaxError] = e;
            s.bytes = serialize_metadata(md);
            s.info.raw_size = s.bytes.size();
            s.info.flags &= ~kSectionZstd;
        }
}

void set_mode(Section& s, uint32_t mode) {
    s.info.flags = (s.info.flags & ~kSectionModeMask) | (mode << kSectionModeShift);
}

}  // namespace

TEST(LatticeModeHostile, RefusedWithSpecificErrors) {
    const Volume v = lattice_field({13, 11, 9}, ValueType::F32, 0.5);
    const File good = split(encode(v, 0.5, int(kLattice)));
    ASSERT_EQ(decode_failure(good).code, ErrorCode::Ok);
    const std::size_t ls = first_lattice(good);
    {  // in a lossless file (no LOSSY, no field.max_error): no step
        File f = good;
        f.features &= ~kFeatureLossy;
        set_max_error(f, "");
        expect(f, ErrorCode::CorruptData, "lattice chunk in a file without a lattice step");
    }
    {  // a field-only mode in HT_ERRORS
        File f = good;
        for (auto& s : f.sections)
            if (s.info.type == kSectionHtErrors && s.info.raw_size > 0 && !(s.info.flags & kSectionZstd)) {
                set_mode(s, kLattice);
                break;
            }
        expect(f, ErrorCode::UnsupportedFeature, "for error codes");
    }
    {  // flagged ZSTD
        File f = good;
        f.sections[ls].info.flags |= kSectionZstd;
        f.sections[ls].bytes = zstd_compress(f.sections[ls].bytes, 1);
        expect(f, ErrorCode::CorruptData, "must not be zstd");
    }
    {  // too short for any stream
        File f = good;
        f.sections[ls].bytes.resize(3);
        f.sections[ls].info.raw_size = 3;
        expect(f, ErrorCode::CorruptData, "impossible");
    }
    {  // truncated by one byte: the stream does not end at its last byte
        File f = good;
        f.sections[ls].bytes.pop_back();
        f.sections[ls].info.raw_size -= 1;
        const Failure got = decode_failure(f);
        EXPECT_EQ(got.code, ErrorCode::CorruptData) << got.message;
    }
    {  // an unknown mode above the last one (range-exp, 7, since 3.8)
        File f = good;
        set_mode(f.sections[ls], 8);
        expect(f, ErrorCode::UnsupportedFeature, "unknown chunk mode 8");
    }
    // Random streams and flipped bytes: a clean error or a field, never a crash
    // (run under ASan / UBSan in the sanitizer build).
    std::mt19937 rng(7);
    int refused = 0;
    for (int trial = 0; trial < 300; ++trial) {
        File f = good;
        auto& b = f.sections[ls].bytes;
        if (trial % 3 == 0) {
            for (auto& x : b) x = std::byte(rng());
        } else {
            for (int k = 0; k < 1 + trial % 5; ++k) b[rng() % b.size()] ^= std::byte(1u << (rng() % 8));
        }
        const Failure got = decode_failure(f);
        if (got.code != ErrorCode::Ok) {
            ++refused;
            EXPECT_EQ(got.code, ErrorCode::CorruptData) << got.message;
        }
    }
    EXPECT_GT(refused, 0);
}

/// An index beyond 2^52 cannot come from the writer; a stream coding one
/// (here: a huge step makes every value 0, and a doctored E turns the
/// decoded integers beyond the type) is refused, not wrapped.
TEST(LatticeModeHostile, ValuesOutsideTheTypeRefused) {
    // u8 with E = 20 (step 41): indices up to 6. Stated E = 100 (step 201) makes q*s > 255.
    const Volume v = lattice_field({13, 11, 9}, ValueType::U8, 20);
    const File good = split(encode(v, 20, int(kLattice)));
    ASSERT_EQ(decode_failure(good).code, ErrorCode::Ok);
    File f = good;
    set_max_error(f, "100");
    expect(f, ErrorCode::CorruptData, "outside");
}
