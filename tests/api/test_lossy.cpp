// Error-bounded lossy archival (format 3.1, spec/tlod-format.md §5.1): every
// value type through write_container(max_error) and back, every decoded
// sample within E of the original; meshes extracted from a lossy container
// honour their bound against the ORIGINAL at every grid point (brute force
// with the independent checker's geometry, tests/support); E = 0 is the
// lossless file byte for byte; hostile field.max_error values are refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "support/mesh_checker.hpp"
#include "support/mt_beside_ht.hpp"
#include "support/volume_generators.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_container.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tetlod/tetlod.hpp"

using namespace tetlod;

namespace {

std::string tmp(const std::string& name) {
    return (std::filesystem::path(TETLOD_TEST_TMP) / (std::to_string(::getpid()) + "_" + name)).string();
}

/// Whether a field chunk uses the range-2d mode (format 3.6, spec §6.4).
bool uses_range2d(const ContainerInfo& info) {
    return std::any_of(info.sections.begin(), info.sections.end(), [](const tlod::SectionInfo& s) {
        return s.type == tlod::kSectionHtField && tlod::section_mode(s.flags) == 5;
    });
}

/// Whether an error chunk uses the range-exp mode (format 3.8, spec §6.4, §8.4).
bool uses_range_exp(const ContainerInfo& info) {
    return std::any_of(info.sections.begin(), info.sections.end(), [](const tlod::SectionInfo& s) {
        return s.type == tlod::kSectionHtErrors && tlod::section_mode(s.flags) == 7;
    });
}

std::vector<char> file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

long double sample(const Volume& v, int64_t i) {
    return dispatch_value_type(v.type, [&](auto tag) {
        using T = decltype(tag);
        return static_cast<long double>(v.as<T>()[i]);
    });
}

long double range_of(const Volume& v) {
    long double lo = sample(v, 0), hi = lo;
    for (int64_t i = 1; i < v.count(); ++i) lo = std::min(lo, sample(v, i)), hi = std::max(hi, sample(v, i));
    return hi - lo;
}

/// Number of samples of `stored` farther than E from `original` (long double: exact for every type here).
int64_t beyond(const Volume& original, const Volume& stored, double e) {
    int64_t bad = 0;
    for (int64_t i = 0; i < original.count(); ++i)
        bad += !(std::fabs(sample(stored, i) - sample(original, i)) <= static_cast<long double>(e));
    return bad;
}

ContainerWriteOptions lossy(double e) {
    ContainerWriteOptions o;
    o.max_error = e;
    o.brick_log2 = 1;  // several bricks per cycle on small volumes
    o.created = 0;
    return o;
}

/// A lossy container of a smooth field is smaller than the lossless one (the
/// quantizer follows the coder's predictions, so smooth regions code to zero).
TEST(Lossy, SmallerThanLossless) {
    for (ValueType type : {ValueType::U8, ValueType::I16, ValueType::F32}) {
        const Volume v = test::make_volume({33, 33, 33}, type, test::Field::Smooth);
        const double e = double(range_of(v)) / 100;
        const std::string a = tmp("small_a.tlod"), b = tmp("small_b.tlod");
        write_container(Volume(v), a, lossy(0));
        write_container(Volume(v), b, lossy(e));
        EXPECT_LT(std::filesystem::file_size(b), std::filesystem::file_size(a)) << value_type_name(type);
    }
}

const ValueType kTypes[] = {ValueType::U8,  ValueType::I8,  ValueType::U16, ValueType::I16,
                            ValueType::U32, ValueType::I32, ValueType::F32, ValueType::F64};

TEST(Lossy, EveryTypeRoundTripsWithinE) {
    for (ValueType type : kTypes)
        for (test::Field field : {test::Field::Smooth, test::Field::Noisy}) {
            const Volume v = test::make_volume({13, 9, 7}, type, field);
            const long double r = range_of(v);
            for (double e : {0.5, 3.0, double(r / 100), double(r / 7)}) {
                if (!(e > 0)) continue;
                SCOPED_TRACE(std::string(value_type_name(type)) + " " + test::field_name(field) + " E=" +
                             std::to_string(e));
                const std::string path = tmp("rt.tlod");
                write_container(Volume(v), path, lossy(e));
                const Volume d = decode_container(path).take();
                ASSERT_EQ(d.type, v.type);
                ASSERT_EQ(d.dims, v.dims);
                EXPECT_EQ(beyond(v, d, e), 0);
                // Integers honour, and state, floor(E): below 1 the file is lossless.
                const double stated = is_float(type) ? e : std::floor(e);
                // The writer keeps the lossless file when it is the smallest (noisy fields).
                const ContainerInfo info = inspect_container(path).take();
                EXPECT_TRUE(info.max_error == stated || info.max_error == 0) << info.max_error;
                EXPECT_EQ(beyond(v, d, info.max_error), 0);  // 0: bit-exact values
                EXPECT_EQ(info.header.version_major, 3);
                // The compact table (3.2), lossy or not; 3.3 when a lossy field uses the
                // lattice chunk mode (spec §6.4), which a lossless file never does; 3.6
                // when a field chunk uses the range-2d mode, in either; 3.8 with range-exp.
                EXPECT_EQ(info.header.version_minor, uses_range_exp(info)                              ? 8
                                                     : uses_range2d(info)                              ? 6
                                                     : info.max_error > 0 && info.header.version_minor == 3 ? 3
                                                                                                           : 2);
                EXPECT_EQ((info.header.required_features & tlod::kFeatureLossy) != 0, info.max_error > 0);
                if (field == test::Field::Smooth && stated >= double(range_of(v)) / 100) {
                    EXPECT_GT(info.max_error, 0);  // a smooth field at 1%: the lossy file wins
                }
                // The planes overload reads the volume whole for a lossy field: same bytes.
                const std::string streamed = tmp("rt_stream.tlod");
                auto planes = planes_of(v);
                write_container(*planes, streamed, lossy(e));
                EXPECT_EQ(file_bytes(path), file_bytes(streamed));
            }
        }
}

// Fast decoding (format 3.7), lossy and lossless: static chunks, every sample
// within E (exact when lossless), the same bytes whether the volume is given
// whole or as planes (lossless planes go through the streaming encoder, lossy
// ones small enough to be read whole), and no range-coded field chunk.
TEST(Lossy, FastDecodeKeepsTheBound) {
    for (ValueType type : {ValueType::U8, ValueType::I16, ValueType::F32, ValueType::F64})
        for (test::Field field : {test::Field::Smooth, test::Field::Noisy}) {
            const Volume v = test::make_volume({17, 11, 9}, type, field);
            for (const double e : {0.0, double(range_of(v) / 50)}) {
                SCOPED_TRACE(std::string(value_type_name(type)) + " " + test::field_name(field) +
                             " E=" + std::to_string(e));
                ContainerWriteOptions o = lossy(e);
                o.fast_decode = true;
                const std::string path = tmp("fast.tlod");
                write_container(Volume(v), path, o);
                const Volume d = decode_container(path).take();
                const ContainerInfo info = inspect_container(path).take();
                EXPECT_EQ(beyond(v, d, info.max_error), 0);
                for (const auto& s : info.sections) {
                    const uint32_t mode = tlod::section_mode(s.flags);
                    // Range, lattice and range-2d are the slow modes (an empty chunk is range, no bytes).
                    if (s.type == tlod::kSectionHtField && s.raw_size > 0)
                        EXPECT_TRUE(mode != 0 && mode != 4 && mode != 5) << mode;
                }
                const std::string streamed = tmp("fast_stream.tlod");
                auto planes = planes_of(v);
                write_container(*planes, streamed, o);
                EXPECT_EQ(file_bytes(path), file_bytes(streamed));
            }
        }
}

TEST(Lossy, FloatsFarFromTheStepKeepTheBound) {
    // Magnitudes where 2E is far below the type's spacing, and subnormals: the
    // quantizer must fall back to the sample rather than break the bound.
    for (ValueType type : {ValueType::F32, ValueType::F64}) {
        Volume v = Volume::allocate({5, 4, 3}, type);
        dispatch_value_type(type, [&](auto tag) {
            using T = decltype(tag);
            if constexpr (std::is_floating_point_v<T>) {
                T* p = reinterpret_cast<T*>(v.data.data());
                for (int64_t i = 0; i < v.count(); ++i)
                    p[i] = T((i % 3 == 0 ? 1e30 : i % 3 == 1 ? 3.7e-3 : 1e-40) * ((i & 1) ? -1 : 1) * (1 + i / 7.0));
            }
        });
        for (double e : {1e-3, 0.0123, 1e25}) {
            std::vector<std::byte> q(v.data.begin(), v.data.end());
            quantize_samples(type, q.data(), std::size_t(v.count()), e);
            Volume s = Volume::allocate(v.dims, type);
            std::copy(q.begin(), q.end(), s.data.begin());
            EXPECT_EQ(beyond(v, s, e), 0) << value_type_name(type) << " E=" << e;
        }
    }
}

TEST(Lossy, ZeroIsLosslessByteForByte) {
    const Volume v = test::make_volume({9, 8, 7}, ValueType::I16, test::Field::Smooth);
    const std::string a = tmp("zero_a.tlod"), b = tmp("zero_b.tlod");
    write_container(Volume(v), a, lossy(0));
    ContainerWriteOptions plain = lossy(0);
    plain.max_error = 0;
    write_container(Volume(v), b, plain);
    EXPECT_EQ(file_bytes(a), file_bytes(b));
    const ContainerInfo info = inspect_container(a).take();
    EXPECT_EQ(info.max_error, 0);
    EXPECT_EQ(info.header.version_minor, uses_range_exp(info) ? 8 : uses_range2d(info) ? 6 : 2);  // the compact table
    EXPECT_FALSE(info.header.required_features & tlod::kFeatureLossy);
    // With the full table: the 3.0 file, as before format 3.1 and 3.2.
    ContainerWriteOptions full = lossy(0);
    full.table = tlod::TableLayout::full;
    const std::string c = tmp("zero_c.tlod");
    write_container(Volume(v), c, full);
    const ContainerInfo full_info = inspect_container(c).take();
    EXPECT_FALSE(uses_range2d(full_info));  // the full table is for older readers: no 3.6 chunk
    EXPECT_FALSE(uses_range_exp(full_info));  // nor a 3.8 one
    EXPECT_EQ(full_info.header.version_minor, 0);
    const Volume d = decode_container(a).take();
    EXPECT_TRUE(std::equal(d.data.begin(), d.data.end(), v.data.begin(), v.data.end()));
}

/// Above the memory budget the planes overload streams two candidates
/// (lossless, lattice) instead of reading the volume whole: every sample still
/// within E, the lattice file kept for a smooth float field, and no candidate
/// file left behind. (Its size against the whole-volume path, which tries a
/// third field: docs/archival.md.)
TEST(Lossy, BoundedMemoryStreamsTwoCandidates) {
    // 1.92 M f64 points: the whole path needs ~69 MB, above a 64 MiB budget
    // that the streaming encoder can still work in (thin planes).
    const Volume v = test::make_volume({40, 40, 1200}, ValueType::F64, test::Field::Smooth);
    const double e = double(range_of(v)) / 100;
    ContainerWriteOptions o = lossy(e);
    o.brick_log2 = 2;
    o.memory_bytes = std::size_t{64} << 20;
    ASSERT_FALSE(lossy_reads_whole(v, o.memory_bytes));
    ASSERT_TRUE(lossy_reads_whole(v, std::size_t{1} << 30));
    const std::string streamed = tmp("bounded_stream.tlod");
    auto planes = planes_of(v);
    const ContainerWriteSummary s = write_container(*planes, streamed, o);
    EXPECT_EQ(s.max_error, e);  // a smooth float field: the lattice file wins
    const Volume d = decode_container(streamed).take();
    ASSERT_EQ(d.dims, v.dims);
    EXPECT_EQ(beyond(v, d, e), 0);
    const ContainerInfo info = inspect_container(streamed).take();
    EXPECT_EQ(info.max_error, e);
    EXPECT_TRUE(info.header.required_features & tlod::kFeatureLossy);
    for (const auto& entry : std::filesystem::directory_iterator(TETLOD_TEST_TMP))
        EXPECT_EQ(entry.path().filename().string().find(".tetlod-lossy-"), std::string::npos) << entry.path();
}

TEST(Lossy, BoundAgainstOriginalRoundsUp) {
    for (float s : {0.0f, 1e-7f, 0.3f, 1.0f, 255.0f, 3.4e38f})
        for (double e : {1e-9, 0.1, 0.5, 2.55, 1e30}) {
            const float b = bound_against_original(s, e);
            EXPECT_GE(static_cast<long double>(b), static_cast<long double>(s) + e) << s << " + " << e;
        }
    EXPECT_TRUE(std::isinf(bound_against_original(std::numeric_limits<float>::infinity(), 1.0)));
}

TEST(Lossy, MtAloneRefused) {
    const Volume v = test::make_volume({6, 5, 4}, ValueType::U8, test::Field::Smooth);
    ContainerWriteOptions o = lossy(2);
    o.mt = true;
    o.ht = false;  // a lossy field lives in the HT
    EXPECT_THROW(write_container(Volume(v), tmp("mt.tlod"), o), Error);
}

/// The largest |L_T(p) - original(p)| over the grid points p of the closed tet,
/// L_T interpolating the mesh's (stored) vertex values; exact barycentric
/// numerators (integer determinants), long double values.
long double tet_error_vs_original(const Volume& original, const TetMesh& mesh, std::size_t t) {
    const test::TetPts P = test::tet_points(mesh, t);
    const int64_t D = test::tet_det(P);
    long double fv[4];
    for (int i = 0; i < 4; ++i) {
        const uint32_t id = mesh.tets[t][std::size_t(i)];
        fv[i] = static_cast<long double>(mesh.values[id]);
    }
    long double worst = 0;
    test::for_each_tet_point(P, [&](const test::Pt& p, bool) {
        long double l = 0;
        for (int i = 0; i < 4; ++i) {
            test::TetPts Q = P;
            Q[std::size_t(i)] = p;
            l += static_cast<long double>(test::tet_det(Q)) / D * fv[i];
        }
        const int64_t idx = (int64_t(p[2]) * original.dims.y + p[1]) * original.dims.x + p[0];
        worst = std::max(worst, std::fabs(l - sample(original, idx)));
    });
    return worst;
}

TEST(Lossy, ExtractHonoursTheBoundAgainstTheOriginal) {
    for (ValueType type : {ValueType::U8, ValueType::I16, ValueType::F32}) {
        const Volume v = test::make_volume({17, 13, 9}, type, test::Field::Smooth);
        const double r = double(range_of(v));
        const double E = r * 0.02;
        const std::string path = tmp("extract.tlod");
        write_container(Volume(v), path, lossy(E));
        ASSERT_GT(inspect_container(path).take().max_error, 0);  // the case under test
        const Volume stored = decode_container(path).take();
        const double tol = is_float(type) ? 1e-9 * r : 1e-9;  // long double interpolation slack
        for (double e : {0.0, E / 2, E, 3 * E, 0.1 * r, 0.3 * r})
            for (bool box : {false, true}) {
                SCOPED_TRACE(std::string(value_type_name(type)) + " e=" + std::to_string(e) + (box ? " box" : ""));
                LodQuery q;
                q.error_in = e;
                if (box) {
                    q.box = std::array<int64_t, 6>{3, 2, 1, 10, 8, 5};
                    q.error_out = std::numeric_limits<double>::infinity();
                }
                const ContainerExtract x = extract_from_container(path, ModelKind::Ht, q).take();
                const TetMesh& m = x.mesh;
                EXPECT_EQ(x.field_max_error, inspect_container(path).take().max_error);
                // What the container says each tet honours, loaded lazily and in memory.
                const TetMesh in_memory = load_ht_model(path).extract(q);
                ASSERT_EQ(in_memory.error, m.error);
                // Structure against the stored field (the mesh's vertex values are its samples).
                test::CheckOptions co;
                co.tolerance = test::float_tolerance(stored);
                EXPECT_TRUE(test::mesh_ok(stored, m, co));
                // The bound against the original: e where the query asks for it, and never
                // below E (the finest mesh honours E, not 0).
                const test::Pt lo{3, 2, 1}, hi{10, 8, 5};
                int64_t bad = 0;
                for (std::size_t t = 0; t < m.tet_count(); ++t) {
                    if (box && !test::tet_meets_box(test::tet_points(m, t), lo, hi)) continue;
                    bad += !(tet_error_vs_original(v, m, t) <= std::max(e, E) + tol);
                }
                EXPECT_EQ(bad, 0);
                // Every tet's stated error is a bound against the original, the finest
                // (unit) tets' too: never below E, though their grid points are vertices.
                int64_t understated = 0;
                for (std::size_t t = 0; t < m.tet_count(); ++t)
                    understated += !(tet_error_vs_original(v, m, t) <= double(m.error[t]) + tol) ||
                                   !(double(m.error[t]) >= x.field_max_error);
                EXPECT_EQ(understated, 0);
                EXPECT_GE(x.max_error, x.field_max_error);
            }
    }
}

/// The MT beside a lossy HT (format 3.5): built on the stored field, its update
/// errors stored with E added, so every MT query honours its bound against the
/// original, and every tet's stated error (E for the reference tets) holds.
TEST(Lossy, MtBesideTheHtHonoursTheBoundAgainstTheOriginal) {
    for (ValueType type : {ValueType::U8, ValueType::I16, ValueType::F32}) {
        const Volume v = test::make_volume({17, 13, 9}, type, test::Field::Smooth);
        const double r = double(range_of(v));
        const double E = r * 0.02;
        const std::string path = tmp("lossy_mt.tlod");
        ContainerWriteOptions o = lossy(E);
        o.mt = true;
        const ContainerWriteSummary s = write_container(Volume(v), path, o);
        const ContainerInfo info = inspect_container(path).take();
        ASSERT_GT(info.max_error, 0);  // the case under test
        EXPECT_EQ(s.max_error, info.max_error);
        EXPECT_GT(s.mt_updates, 0u);
        EXPECT_EQ(info.header.version_minor, uses_range_exp(info) ? 8 : uses_range2d(info) ? 6 : 5);  // LOSSY_MT; 3.6 includes it
        EXPECT_TRUE(info.header.required_features & tlod::kFeatureLossy);
        EXPECT_TRUE(info.header.required_features & tlod::kFeatureLossyMt);
        ASSERT_TRUE(info.mt);
        const Volume stored = decode_container(path).take();
        EXPECT_EQ(beyond(v, stored, info.max_error), 0);
        // The MT's field is the HT's stored one.
        const MtModel mt = load_mt_model(path);
        EXPECT_EQ(mt.field().data, stored.data);
        EXPECT_GE(double(mt.field_error_bound()), info.max_error);  // E rounded up to float
        EXPECT_LT(double(std::nextafter(mt.field_error_bound(), 0.0f)), info.max_error);
        const double tol = is_float(type) ? 1e-9 * r : 1e-9;
        for (double e : {0.0, E / 2, E, 3 * E, 0.1 * r, 0.3 * r}) {
            SCOPED_TRACE(std::string(value_type_name(type)) + " e=" + std::to_string(e));
            LodQuery q;
            q.error_in = e;
            const ContainerExtract x = extract_from_container(path, ModelKind::Mt, q).take();
            const TetMesh& m = x.mesh;
            EXPECT_EQ(x.field_max_error, info.max_error);
            test::CheckOptions co;
            co.tolerance = test::float_tolerance(stored);
            EXPECT_TRUE(test::mesh_ok(stored, m, co));
            int64_t bad = 0, understated = 0;
            for (std::size_t t = 0; t < m.tet_count(); ++t) {
                const long double against = tet_error_vs_original(v, m, t);
                bad += !(against <= std::max(e, info.max_error) + tol);
                understated += !(against <= double(m.error[t]) + tol) || !(double(m.error[t]) >= info.max_error);
            }
            EXPECT_EQ(bad, 0);
            EXPECT_EQ(understated, 0);
            EXPECT_GE(x.max_error, info.max_error);
        }
    }
}

/// A LOSSY_MT file whose MT did not add E (an update error below it) is refused:
/// its bounds would be those of the stored field.
TEST(Lossy, MtErrorsBelowTheFieldsBoundRefused) {
    const Volume v = test::make_volume({17, 13, 9}, ValueType::U8, test::Field::Smooth);
    const std::string ht_only = tmp("lossy_ht_only.tlod");
    write_container(Volume(v), ht_only, lossy(3));
    const ContainerInfo info = inspect_container(ht_only).take();
    ASSERT_EQ(info.max_error, 3.0);
    const Volume stored = decode_container(ht_only).take();
    const MtModel mt = MtModel::build(stored);
    // (MtModel::build copies the stored field: its metadata is the stored volume's.)
    auto build = [&](double field_error, const std::string& name) {
        const std::string out = tmp(name);
        test::write_mt_beside_ht(ht_only, mt, field_error, out);
        return out;
    };
    const std::string honest = build(3, "lossy_mt_honest.tlod");
    EXPECT_TRUE(decode_mt_container(*tlod::ContainerReader::open(honest)).ok());
    const std::string forgot = build(1e-3, "lossy_mt_forgot.tlod");
    auto r = tlod::ContainerReader::open(forgot);
    ASSERT_TRUE(r.ok());  // the header is consistent: the MT's errors are what is wrong
    const auto m = decode_mt_container(*r);
    ASSERT_FALSE(m.ok());
    EXPECT_EQ(m.failure().code, ErrorCode::CorruptData);
    EXPECT_NE(m.failure().message.find("below the field's E"), std::string::npos) << m.failure().message;
}

/// The MT's encoder takes E exactly beside a lossy HT, and never alone.
TEST(Lossy, MtFieldErrorOnlyBesideALossyHt) {
    const Volume v = test::make_volume({6, 5, 4}, ValueType::U8, test::Field::Smooth);
    const MtModel mt = MtModel::build(v);
    const tlod::Metadata meta = tlod::metadata_for_volume(v);
    MtEncodeOptions with_e;
    with_e.field_error = 2;
    tlod::ContainerWriter alone;
    EXPECT_THROW(encode_mt_container(mt, meta, alone, false, with_e), Error);
    tlod::ContainerWriter lossless;  // an HT without LOSSY: E is refused
    lossless.set_features(tlod::kFeatureHt);
    EXPECT_THROW(encode_mt_container(mt, meta, lossless, true, with_e), Error);
    tlod::ContainerWriter lossy_ht;  // a lossy HT: E is required
    lossy_ht.set_features(tlod::kFeatureHt | tlod::kFeatureLossy);
    EXPECT_THROW(encode_mt_container(mt, meta, lossy_ht, true, MtEncodeOptions{}), Error);
    encode_mt_container(mt, meta, lossy_ht, true, with_e);
    EXPECT_EQ(lossy_ht.required_features(), tlod::kFeatureHt | tlod::kFeatureLossy | tlod::kFeatureLossyMt);
    with_e.field_error = -1;
    tlod::ContainerWriter negative;
    negative.set_features(tlod::kFeatureHt | tlod::kFeatureLossy);
    EXPECT_THROW(encode_mt_container(mt, meta, negative, true, with_e), Error);
}

/// The container at `path` rewritten with its METADATA format keys changed by
/// `edit` and the required features given (checksums recomputed).
std::string rewritten(const std::string& path, const std::string& name,
                      const std::function<void(std::map<std::string, std::string>&)>& edit, uint64_t features,
                      uint64_t optional = 0) {
    auto r = tlod::ContainerReader::open(path).take();
    tlod::ContainerWriter w;
    w.set_features(features, optional);
    for (std::size_t i = 0; i < r.sections().size(); ++i) {
        const tlod::SectionInfo s = r.sections()[i];
        if (s.type == tlod::kSectionMetadata) {
            tlod::Metadata md = tlod::parse_metadata(r.read_section(i).take()).take();
            edit(md.format_keys);
            w.add(s.type, s.flags & ~tlod::kSectionZstd, 0, 0, tlod::serialize_metadata(md), 3);
        } else {
            w.add_stored(s.type, s.flags, s.arg0, s.arg1, r.read_stored(i).take(), s.raw_size);
        }
    }
    const std::string out = tmp(name);
    w.write(out);
    return out;
}

TEST(Lossy, HostileMaxErrorRefused) {
    const Volume v = test::make_volume({9, 7, 5}, ValueType::U8, test::Field::Smooth);
    const std::string path = tmp("hostile_src.tlod");
    write_container(Volume(v), path, lossy(20));
    ASSERT_GT(inspect_container(path).take().max_error, 0);
    const uint64_t lossy_features = tlod::kFeatureHt | tlod::kFeatureLossy;
    int n = 0;
    for (const char* bad : {"-1", "nan", "inf", "-inf", "0", "-0", "1e999", "abc", "", "2 ", "0x10"}) {
        const std::string f = rewritten(
            path, "hostile" + std::to_string(n++) + ".tlod",
            [&](auto& k) { k[tlod::kKeyFieldMaxError] = bad; }, lossy_features);
        const auto opened = open_model(f, ModelKind::Ht);
        ASSERT_FALSE(opened) << "'" << bad << "' accepted";
        EXPECT_EQ(opened.failure().code, ErrorCode::CorruptData) << bad;
        EXPECT_NE(opened.failure().message.find("field.max_error"), std::string::npos) << opened.failure().message;
        EXPECT_FALSE(decode_container(f));
    }
    // The feature without the key, the key without the feature: refused.
    const std::string no_key =
        rewritten(path, "no_key.tlod", [](auto& k) { k.erase(tlod::kKeyFieldMaxError); }, lossy_features);
    EXPECT_FALSE(decode_container(no_key));
    const std::string no_bit = rewritten(path, "no_bit.tlod", [](auto&) {}, tlod::kFeatureHt);
    EXPECT_FALSE(decode_container(no_bit));
    // LOSSY next to an MT (optional bit) needs LOSSY_MT (3.5), which says that the
    // MT's errors include E; LOSSY_MT needs both.
    const std::string with_mt = rewritten(path, "with_mt.tlod", [](auto&) {}, lossy_features, tlod::kFeatureMt);
    EXPECT_FALSE(tlod::ContainerReader::open(with_mt));
    const std::string mt_bit_only =
        rewritten(path, "mt_bit_only.tlod", [](auto&) {}, lossy_features | tlod::kFeatureLossyMt);
    EXPECT_FALSE(tlod::ContainerReader::open(mt_bit_only));
    // Untouched, it opens (the rewrite itself is sound).
    EXPECT_TRUE(decode_container(rewritten(path, "same.tlod", [](auto&) {}, lossy_features)));
}

}  // namespace
