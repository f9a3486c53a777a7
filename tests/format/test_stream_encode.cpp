// The out-of-core HT encoder (plane by plane, bounded memory) against the
// in-memory one: the same container bytes on awkward dims, every value type,
// padded and not, small and default bricks, budgets from "one plane per slab"
// to "64 planes per slab", and 1 or 2 threads. Its diamond errors are also
// checked against the whole-field computation through the public sweep.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <fstream>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/ht/ht_distributed.hpp"
#include "tetlod/codecs/lossy_field.hpp"
#include "tetlod/models/ht/ht_error_sweep.hpp"
#include "tlod_test_util.hpp"
#include "support/volume_generators.hpp"

using namespace tetlod;

namespace {

struct TempPath {
    std::string path;
    explicit TempPath(const std::string& name)
        : path((std::filesystem::temp_directory_path() /
                ("tetlod_stream_" + std::to_string(::getpid()) + "_" + name))
                   .string()) {}
    ~TempPath() { std::filesystem::remove(path); }
};

std::vector<std::byte> read_all(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::vector<char> c((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::vector<std::byte> b(c.size());
    std::memcpy(b.data(), c.data(), c.size());
    return b;
}

tlod::Metadata meta_of(const Volume& v) {
    tlod::Metadata m = tlod::metadata_for_volume(v);
    m.format_keys["converter"] = "test";
    return m;
}

std::vector<std::byte> in_memory_bytes(const Volume& v, bool pad, const HtEncodeOptions& eo) {
    HtBuildOptions bo;
    bo.pad = pad;
    const HtModel model = HtModel::build(v, bo);
    tlod::ContainerWriter w;
    encode_ht(model, meta_of(v), w, eo);
    return w.finish();
}

std::vector<std::byte> streamed_bytes(const Volume& v, bool pad, const HtEncodeOptions& eo, std::size_t memory,
                                      HtStreamEncodeSummary* summary = nullptr, int slab = 0) {
    TempPath out("out.tlod");
    auto planes = planes_of(v);
    HtStreamEncodeOptions so;
    so.encode = eo;
    so.pad = pad;
    so.memory_bytes = memory;
    so.slab_planes = slab;
    tlod::Metadata meta = meta_of(v);
    meta.value_range = {12345, 6789};  // replaced by the range the scan finds
    const auto s = write_ht_container_streaming(*planes, meta, out.path, so);
    if (summary) *summary = s;
    return read_all(out.path);
}

struct Case {
    Dims dims;
    ValueType type;
    test::Field field;
    bool pad;
    int brick_log2;
};

std::string name_of(const Case& c) {
    return std::to_string(c.dims.x) + "x" + std::to_string(c.dims.y) + "x" + std::to_string(c.dims.z) + " " +
           value_type_name(c.type) + " " + test::field_name(c.field) + (c.pad ? " padded" : "") + " g" +
           std::to_string(c.brick_log2);
}

}  // namespace

TEST(StreamEncode, SameBytesAsInMemory) {
    const std::vector<Case> cases = {
        {{2, 2, 2}, ValueType::U8, test::Field::Noisy, false, 4},
        {{18, 2, 7}, ValueType::I16, test::Field::Smooth, false, 1},
        {{65, 3, 5}, ValueType::F32, test::Field::Noisy, true, 2},
        {{33, 33, 33}, ValueType::U8, test::Field::Plateau, false, 1},
        // k = 7: diamonds up to h = 64, accumulated slab by slab from the coarse lattice.
        {{70, 41, 66}, ValueType::U8, test::Field::Smooth, false, 4},
        {{70, 41, 66}, ValueType::U8, test::Field::Noisy, true, 1},
        {{67, 35, 80}, ValueType::F32, test::Field::Smooth, false, 2},
        {{67, 35, 80}, ValueType::F64, test::Field::Noisy, false, 4},
        {{66, 66, 66}, ValueType::I32, test::Field::Noisy, false, 3},  // 128-bit accumulators
        {{40, 70, 35}, ValueType::U16, test::Field::Smooth, true, 2},
        {{35, 34, 70}, ValueType::I8, test::Field::Constant, false, 1},
        // z max 28 is a multiple of the side of cycle 0 and 1 rows (4, 8): the
        // last row also owns plane 28 in the METADATA error summary.
        {{40, 33, 29}, ValueType::F64, test::Field::Smooth, false, 1},
        {{36, 37, 38}, ValueType::U32, test::Field::Smooth, false, 2},
    };
    for (const Case& c : cases) {
        const Volume v = test::make_volume(c.dims, c.type, c.field, 7);
        HtEncodeOptions eo;
        eo.brick_log2 = c.brick_log2;
        eo.zstd_level = 3;
        const auto want = in_memory_bytes(v, c.pad, eo);
        // Slabs of 1 plane (the smallest budget's plan), 3 (not a power of
        // two, never aligned with bricks) and 64 (the default plan).
        for (int slab : {1, 3, 0}) {
            HtStreamEncodeSummary s;
            const auto got = streamed_bytes(v, c.pad, eo, std::size_t{1} << 30, &s, slab);
            EXPECT_EQ(s.slab_planes, slab == 0 ? 64 : slab) << name_of(c);
            ASSERT_EQ(got.size(), want.size()) << name_of(c) << " slab " << slab;
            EXPECT_TRUE(got == want) << name_of(c) << " slab " << slab;
        }
    }
}

TEST(StreamEncode, OneAndTwoThreadsGiveTheSameBytes) {
    // Chunks of thousands of diamonds, so that the two error codings of a chunk
    // run as parallel tasks; several two-thread encodes, since which thread
    // takes which task changes from run to run (a task reading the wrong
    // thread's scratch showed in about one encode in four).
    for (ValueType type : {ValueType::F32, ValueType::U8}) {
        const Volume v = test::make_volume({70, 45, 67}, type, test::Field::Smooth, 3);
        HtEncodeOptions eo;
        eo.zstd_level = 3;
        std::vector<std::byte> one;
        {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
            one = streamed_bytes(v, false, eo, std::size_t{1} << 30);
        }
        for (int run = 0; run < 4; ++run) {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
            EXPECT_TRUE(one == streamed_bytes(v, false, eo, std::size_t{1} << 30)) << value_type_name(type) << " run " << run;
            EXPECT_TRUE(one == in_memory_bytes(v, false, eo)) << value_type_name(type) << " run " << run;
        }
    }
}

TEST(StreamEncode, TooSmallABudgetSaysWhatItNeeds) {
    const Volume v = test::make_volume({70, 41, 66}, ValueType::U8, test::Field::Smooth, 7);
    HtEncodeOptions eo;
    eo.zstd_level = 3;
    std::size_t need = 0;
    try {
        streamed_bytes(v, false, eo, std::size_t{1} << 20);
        FAIL() << "1 MiB was enough";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::InvalidArgument);
        const std::string msg = e.what();
        EXPECT_NE(msg.find("--memory"), std::string::npos) << msg;
        const auto at = msg.find("at least ");
        ASSERT_NE(at, std::string::npos) << msg;
        need = std::stoull(msg.substr(at + 9)) << 20;
    }
    // What it asked for is enough, and gives the same bytes.
    HtStreamEncodeSummary s;
    const auto got = streamed_bytes(v, false, eo, need, &s);
    EXPECT_GE(s.slab_planes, 1);
    EXPECT_LE(s.planned_bytes, need);
    EXPECT_TRUE(got == in_memory_bytes(v, false, eo));
}

TEST(StreamEncode, NonFiniteValueIsRefusedWithItsPosition) {
    Volume v = test::make_volume({20, 21, 22}, ValueType::F32, test::Field::Smooth, 1);
    v.as<float>()[v.dims.index(3, 4, 5)] = std::numeric_limits<float>::quiet_NaN();
    TempPath out("nan.tlod");
    auto planes = planes_of(v);
    try {
        write_ht_container_streaming(*planes, meta_of(v), out.path);
        FAIL() << "a NaN was accepted";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::CorruptData);
        EXPECT_NE(std::string(e.what()).find("(3,4,5)"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(out.path));
}

TEST(StreamEncode, MetadataMustDescribeTheVolume) {
    const Volume v = test::make_volume({20, 21, 22}, ValueType::U8, test::Field::Smooth, 1);
    tlod::Metadata m = meta_of(v);
    m.dims.x = 19;
    TempPath out("bad.tlod");
    auto planes = planes_of(v);
    EXPECT_THROW(write_ht_container_streaming(*planes, m, out.path), Error);
}

namespace {

/// The errors of parts of B served to the encoder, as tetlod-mpi's rank 0
/// does with the other ranks' (packed, then unpacked into the encoder's planes).
class PartsSource final : public HtErrorSource {
public:
    PartsSource(std::array<double, 2> range, const std::vector<std::unique_ptr<HtRangeErrors>>& parts)
        : range_(range), parts_(parts) {}
    std::array<double, 2> range() const override { return range_; }
    void fill(int64_t za, int64_t zb, HtErrorPlaneSink& sink) override {
        for (const auto& p : parts_) {
            const int64_t z1 = std::max(za, p->za()), z2 = std::min(zb, p->zb());
            if (z1 > z2) continue;
            std::vector<float> packed(ht_packed_error_floats(p->domain(), z1, z2));
            p->pack(z1, z2, packed.data());
            ht_unpack_errors(p->domain(), z1, z2, packed.data(), sink);
        }
    }

private:
    std::array<double, 2> range_;
    const std::vector<std::unique_ptr<HtRangeErrors>>& parts_;
};

/// The scan and the final errors of `parts` ranges of planes, merged as tetlod-mpi
/// merges them (the partial maxima reduced over the parts).
struct ErrorsInParts {
    HtScanPart scan;
    std::vector<std::unique_ptr<HtRangeErrors>> errors;
};
ErrorsInParts errors_in_parts(VolumePlanes& source, const HtDomain& d, bool pad, int parts) {
    const int64_t planes = int64_t(d.box_max[2]) + 1;
    ErrorsInParts out;
    for (int r = 0; r < parts; ++r) {
        const HtScanPart part = ht_scan_planes(source, pad, planes * r / parts, planes * (r + 1) / parts - 1);
        if (r == 0) out.scan = part;
        else ht_merge_scan(out.scan, part);
    }
    auto& errors = out.errors;
    for (int r = 0; r < parts; ++r) {
        errors.push_back(std::make_unique<HtRangeErrors>(source, pad, out.scan.range, out.scan.coarse,
                                                         planes * r / parts, planes * (r + 1) / parts - 1, 5));
        errors.back()->compute();
    }
    // As tetlod-mpi's MPI_Allreduce: the user operation (merge_maxima) folds
    // the parts' buffers, here in pieces of 3 maxima (MPI may cut a reduction
    // at any whole element), from the last part down; every part then merges
    // the total into its own maxima.
    std::vector<std::byte> total = errors.back()->partial_maxima();
    const std::size_t piece = 3 * errors[0]->partial_maximum_bytes();
    for (int q = parts - 2; q >= 0; --q) {
        const std::vector<std::byte> theirs = errors[std::size_t(q)]->partial_maxima();
        for (std::size_t at = 0; at < total.size(); at += piece)
            errors[0]->merge_maxima(theirs.data() + at, total.data() + at, std::min(piece, total.size() - at));
    }
    for (auto& e : errors) {
        e->merge_partial_maxima(total.data(), total.size());
        e->finish();
    }
    return out;
}

/// The streaming encoder's bytes with range and errors computed in `parts`
/// ranges of B planes (ht_distributed.hpp), merged as tetlod-mpi merges them.
std::vector<std::byte> distributed_bytes(const Volume& v, bool pad, const HtEncodeOptions& eo, int parts) {
    const HtDomain d = HtDomain::for_dims(v.dims, pad);
    auto source = planes_of(v);
    auto [scan, errors] = errors_in_parts(*source, d, pad, parts);
    PartsSource from_parts(scan.range, errors);
    TempPath out("distributed.tlod");
    HtStreamEncodeOptions so;
    so.encode = eo;
    so.pad = pad;
    so.errors = &from_parts;
    tlod::Metadata meta = meta_of(v);
    meta.value_range = {12345, 6789};  // replaced by the source's range
    write_ht_container_streaming(*planes_of(v), meta, out.path, so);
    return read_all(out.path);
}

}  // namespace

// The hooks of a distributed conversion: any split of the planes gives the
// serial bytes (large diamonds spanning several parts, parts holding only
// padded planes, parts thinner than the sweep's reach).
TEST(StreamEncode, ErrorsComputedInPartsGiveTheSameBytes) {
    const std::vector<Case> cases = {
        {{2, 2, 2}, ValueType::U8, test::Field::Noisy, false, 4},
        {{65, 3, 5}, ValueType::F32, test::Field::Noisy, true, 2},
        {{70, 41, 66}, ValueType::U8, test::Field::Smooth, false, 4},
        {{70, 41, 66}, ValueType::U8, test::Field::Noisy, true, 1},
        {{67, 35, 80}, ValueType::F64, test::Field::Noisy, false, 4},
        {{66, 66, 66}, ValueType::I32, test::Field::Noisy, false, 3},  // 128-bit accumulators
        {{35, 34, 70}, ValueType::I8, test::Field::Constant, false, 1},
        // z max 28 is a multiple of the side of cycle 0 and 1 rows (4, 8): the
        // last row also owns plane 28 in the METADATA error summary.
        {{40, 33, 29}, ValueType::F64, test::Field::Smooth, false, 1},
    };
    for (const Case& c : cases) {
        const Volume v = test::make_volume(c.dims, c.type, c.field, 7);
        HtEncodeOptions eo;
        eo.brick_log2 = c.brick_log2;
        eo.zstd_level = 3;
        const auto want = streamed_bytes(v, c.pad, eo, std::size_t{1} << 30);
        for (int parts : {1, 2, 3, 7}) {
            const auto got = distributed_bytes(v, c.pad, eo, parts);
            ASSERT_EQ(got.size(), want.size()) << name_of(c) << ", " << parts << " parts";
            EXPECT_TRUE(got == want) << name_of(c) << ", " << parts << " parts";
        }
    }
}

namespace {

/// The container tetlod-mpi writes with encoding on every process (§3.6 step
/// 3): errors in `parts` ranges of planes, each part encoding the rows of
/// bricks starting in its planes from lattice planes (its own or another
/// part's errors), the file laid out from the sections' entries alone.
std::vector<std::byte> rows_in_parts_bytes(const Volume& v, bool pad, const HtEncodeOptions& eo, int parts) {
    const HtDomain d = HtDomain::for_dims(v.dims, pad);
    const int64_t planes = int64_t(d.box_max[2]) + 1;
    auto source = planes_of(v);
    auto [scan, errors] = errors_in_parts(*source, d, pad, parts);
    const auto owner = [&](int64_t z) {
        for (int r = 0; r < parts; ++r)
            if (z < planes * (r + 1) / parts) return r;
        return parts - 1;
    };
    const std::size_t vs = value_size(v.type);
    std::vector<HtSection> sections;
    HtRowEncoder::ErrorStats stats;
    // Parts in reverse order: the layout must not depend on the entries' order.
    for (int r = parts; r-- > 0;) {
        HtRowEncoder enc(d, v.type, eo);
        for (const HtBrickRow& row : ht_rows_in(d, eo.brick_log2, planes * r / parts, planes * (r + 1) / parts - 1)) {
            const auto w = ht_row_window(d, eo.brick_log2, row);
            const std::size_t pp = std::size_t(ht_lattice_plane_points(d, row.t));
            std::vector<std::byte> values;
            std::vector<float> errs;
            for (int64_t z = w[0]; z <= w[1]; z += int64_t{1} << row.t) {
                values.resize(values.size() + pp * vs);
                ht_lattice_values(*source, pad, row.t, z, values.data() + values.size() - pp * vs);
                if (row.t < d.k) {
                    const float* e = errors[std::size_t(owner(z))]->error_plane(row.t, z);
                    errs.insert(errs.end(), e, e + pp);
                }
            }
            enc.encode(row, values.data(), row.t < d.k ? errs.data() : nullptr, sections);
        }
        stats.raw_max = std::max(stats.raw_max, enc.error_stats().raw_max);
        stats.always_split += enc.error_stats().always_split;
    }
    std::vector<HtSectionEntry> entries;
    for (const HtSection& s : sections)
        entries.push_back({s.type, s.flags, s.cycle, s.brick, s.bytes.size(), s.raw_size, s.checksum});
    tlod::Metadata meta = meta_of(v);
    meta.value_range = scan.range;
    const HtContainerLayout layout = ht_distributed_layout(d, meta, stats, eo, entries);
    std::vector<std::byte> file(layout.file_size);
    EXPECT_LE(layout.head.size(), file.size());
    std::copy(layout.head.begin(), layout.head.end(), file.begin());
    for (std::size_t i = 0; i < sections.size(); ++i) {
        EXPECT_LE(layout.offsets[i] + sections[i].bytes.size(), file.size());
        std::copy(sections[i].bytes.begin(), sections[i].bytes.end(), file.begin() + std::ptrdiff_t(layout.offsets[i]));
    }
    // Every section exactly once: a missing one is refused.
    entries.pop_back();
    EXPECT_THROW(ht_distributed_layout(d, meta, stats, eo, entries), Error);
    return file;
}

}  // namespace

// Encoding on every process: rows of bricks encoded apart and laid out from
// their entries give the serial bytes (rows whose windows cross parts, coarse
// rows spanning every part, parts holding no row start, padded planes).
TEST(StreamEncode, RowsEncodedInPartsGiveTheSameBytes) {
    const std::vector<Case> cases = {
        {{2, 2, 2}, ValueType::U8, test::Field::Noisy, false, 4},
        {{65, 3, 5}, ValueType::F32, test::Field::Noisy, true, 2},
        {{70, 41, 66}, ValueType::U8, test::Field::Smooth, false, 4},
        {{70, 41, 66}, ValueType::U8, test::Field::Noisy, true, 1},
        {{67, 35, 80}, ValueType::F64, test::Field::Noisy, false, 4},
        {{66, 66, 66}, ValueType::I32, test::Field::Noisy, false, 3},
        {{35, 34, 70}, ValueType::I8, test::Field::Constant, false, 1},
        // z max 28 is a multiple of the side of cycle 0 and 1 rows (4, 8): the
        // last row also owns plane 28 in the METADATA error summary.
        {{40, 33, 29}, ValueType::F64, test::Field::Smooth, false, 1},
    };
    for (const Case& c : cases) {
        const Volume v = test::make_volume(c.dims, c.type, c.field, 7);
        HtEncodeOptions eo;
        eo.brick_log2 = c.brick_log2;
        eo.zstd_level = 3;
        const auto want = streamed_bytes(v, c.pad, eo, std::size_t{1} << 30);
        for (int parts : {1, 2, 3, 7}) {
            const auto got = rows_in_parts_bytes(v, c.pad, eo, parts);
            ASSERT_EQ(got.size(), want.size()) << name_of(c) << ", " << parts << " parts";
            EXPECT_TRUE(got == want) << name_of(c) << ", " << parts << " parts";
        }
    }
}

// Lossy fields on the lattice (format 3.3, chunk mode 4): the streaming
// encoder (the bounded-memory lossy path streams such a field) and rows
// encoded in parts (the distributed encoder) choose the lattice mode chunk by
// chunk exactly as the in-memory encoder.
TEST(StreamEncode, LatticeChunksSameBytesInEveryEncoder) {
    const std::vector<Case> cases = {
        {{67, 35, 80}, ValueType::F32, test::Field::Smooth, false, 2},
        // brick_log2 1: the last plane (z = 28) is a multiple of every row's
        // side, so it is the far face of the last row of bricks (before session
        // 12 the streaming summary missed its always-split diamonds).
        {{40, 33, 29}, ValueType::F64, test::Field::Smooth, false, 1},
        {{40, 70, 35}, ValueType::I16, test::Field::Smooth, false, 2},
    };
    for (const Case& c : cases) {
        Volume v = test::make_volume(c.dims, c.type, c.field, 7);
        double lo = INFINITY, hi = -INFINITY;
        dispatch_value_type(c.type, [&](auto tv) {
            using T = decltype(tv);
            for (int64_t i = 0; i < v.count(); ++i) lo = std::min(lo, double(v.as<T>()[i])), hi = std::max(hi, double(v.as<T>()[i]));
        });
        const double e = is_float(c.type) ? (hi - lo) / 100 : std::max(1.5, (hi - lo) / 100);  // 1% of the range
        quantize_volume(v, e);
        HtEncodeOptions eo;
        eo.brick_log2 = c.brick_log2;
        eo.zstd_level = 3;
        eo.max_error = stored_max_error(c.type, e);
        const auto want = in_memory_bytes(v, c.pad, eo);
        auto r = tlod::ContainerReader::from_memory(want);
        ASSERT_TRUE(r.ok());
        int lattice = 0;
        for (const auto& sec : r->sections())
            lattice += sec.type == tlod::kSectionHtField && tlod::section_mode(sec.flags) == 4;
        EXPECT_GT(lattice, 0) << name_of(c);
        int range_exp = 0;  // error chunks of format 3.8, by default
        for (const auto& sec : r->sections())
            range_exp += sec.type == tlod::kSectionHtErrors && tlod::section_mode(sec.flags) == 7;
        EXPECT_EQ(r->header().version_minor, range_exp > 0 ? 8 : 3) << name_of(c);
        for (int slab : {1, 0}) {
            const auto got = streamed_bytes(v, c.pad, eo, std::size_t{1} << 30, nullptr, slab);
            EXPECT_TRUE(got == want) << name_of(c) << " slab " << slab;
        }
        for (int parts : {1, 3}) {
            const auto got = rows_in_parts_bytes(v, c.pad, eo, parts);
            EXPECT_TRUE(got == want) << name_of(c) << ", " << parts << " parts";
        }
    }
}
