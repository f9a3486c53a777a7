// Writes the seed corpora of the fuzz targets (fuzz/corpus/<target>/), small
// valid inputs in each target's input format. Run after a format change:
//   build/fuzz/fuzz_make_corpus fuzz/corpus
// The container reader's seeds (corpus/reader) are the spec's test vectors, plus (format
// 3.2, compact table) an HT+MT and a lossy file written by `tetlod convert` from
// the vectors' raw volumes (SOURCE_DATE_EPOCH=0): ht_mt_v3.2_u8_9x6x5_compact from
// ht_mt_v2.1_u8_9x6x5.raw --model ht,mt; ht_v3.2_i16_17x17x17_lossy_compact from
// ht_v3_i16_17x17x17_samples.raw --max-error 1%. The format 3.3 vectors (lattice chunks) are
// among the spec's test vectors copied here, as are the 3.4 ones (MT_Coding 3), the
// 3.6 ones (range-2d chunks), the 3.7 ones (static chunks) and the 3.8 ones (range-exp error chunks). Seeds written by an earlier version are kept as they are:
// after adding seeds, copy only the new files from a scratch directory.
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <span>
#include <tuple>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

using namespace tetlod;
namespace fs = std::filesystem;

namespace {

void put(const fs::path& p, const void* d, std::size_t n) {
    std::ofstream f(p, std::ios::binary);
    f.write(static_cast<const char*>(d), static_cast<std::streamsize>(n));
}
void put(const fs::path& p, const std::string& s) { put(p, s.data(), s.size()); }

Volume sample(Dims d, ValueType t, unsigned seed) {
    Volume v = Volume::allocate(d, t);
    for (int64_t i = 0; i < d.count(); ++i) {
        const int64_t x = i % d.x, y = (i / d.x) % d.y, z = i / (d.x * d.y);
        v.set_value(i, double((x * 7 + y * 3 + z * 5 + int64_t(seed) * (i % 3)) % 50));
    }
    v.field_name = "density";
    v.metadata["k"] = "v";
    return v;
}

/// The HT sections of a container, as the ht_sections target reads them.
/// Chunk sections (format 3.0) start with "MODE", the mode byte (| 16 when
/// ZSTD) and the raw size, as fuzz_ht_sections.cpp reads them; samples
/// sections are kept as their zstd frame. `mode`: the encoder's chunk_mode.
std::string ht_parts(const Volume& v, int brick_log2, bool pad, int mode = -1) {
    HtBuildOptions bo;
    bo.pad = pad;
    HtModel m = HtModel::build(v, bo);
    tlod::ContainerWriter w;
    HtEncodeOptions eo;
    eo.brick_log2 = brick_log2;
    eo.chunk_mode = mode;
    encode_ht(m, tlod::metadata_for_volume(v), w, eo);
    const auto file = w.finish();
    auto r = tlod::ContainerReader::from_memory(file);
    std::string out;
    for (std::size_t i = 0; i < r->sections().size(); ++i) {
        const tlod::SectionInfo& si = r->sections()[i];
        const bool chunk = si.type == tlod::kSectionHtField || si.type == tlod::kSectionHtErrors;
        auto s = chunk ? r->read_stored(i) : r->read_section(i);
        if (i) out += "@SEC";
        if (chunk) {
            std::vector<std::byte> head;
            const uint8_t f = uint8_t(tlod::section_mode(si.flags) | ((si.flags & tlod::kSectionZstd) ? 16 : 0));
            tlod::put_u8(head, f);
            tlod::put_u64(head, si.raw_size);
            out += "MODE";
            out.append(reinterpret_cast<const char*>(head.data()), head.size());
        }
        out.append(reinterpret_cast<const char*>(s->data()), s->size());
    }
    return out;
}

/// A u8 volume of zeros with a small blob: constant, samples and range chunks.
Volume sparse(Dims d) {
    Volume v = Volume::allocate(d, ValueType::U8);
    for (int64_t z = 0; z < d.z; ++z)
        for (int64_t y = 0; y < d.y; ++y)
            for (int64_t x = 0; x < d.x; ++x)
                if ((x - 3) * (x - 3) + (y - 3) * (y - 3) + (z - 2) * (z - 2) < 5) v.set_value(d.index(x, y, z), 9.0 * x);
    return v;
}

/// A u16 ramp: exact predictions, zero-residual chunks.
Volume linear(Dims d) {
    Volume v = Volume::allocate(d, ValueType::U16);
    for (int64_t z = 0; z < d.z; ++z)
        for (int64_t y = 0; y < d.y; ++y)
            for (int64_t x = 0; x < d.x; ++x) v.set_value(d.index(x, y, z), double(x + 2 * y + 3 * z));
    return v;
}

std::string gzip(const std::string& raw) {
    z_stream zs{};
    deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
    std::string out(deflateBound(&zs, raw.size()) + 32, '\0');
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
    zs.avail_in = uInt(raw.size());
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = uInt(out.size());
    deflate(&zs, Z_FINISH);
    out.resize(zs.total_out);
    deflateEnd(&zs);
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: fuzz_make_corpus CORPUS_DIR\n");
        return 2;
    }
    const fs::path root = argv[1];
    for (const char* d : {"ht_sections", "mt", "metadata", "nrrd", "metaimage"}) fs::create_directories(root / d);
    // HT sections.
    // (The seeds u8_5x4x3_b1, i16_9x9x9_b2 and f32_6x5x4_padded in the corpus
    // are residual coding 2, written by the 2.x version of this program: kept
    // as they are, the decoders still read coding 2.)
    // Format 3.0: every chunk mode.
    put(root / "ht_sections/v3_u8_5x4x3_b1", ht_parts(sample({5, 4, 3}, ValueType::U8, 1), 1, false));
    put(root / "ht_sections/v3_i16_9x9x9_b2_samples", ht_parts(sample({9, 9, 9}, ValueType::I16, 2), 2, false, 2));
    put(root / "ht_sections/v3_f32_6x5x4_padded_samples", ht_parts(sample({6, 5, 4}, ValueType::F32, 3), 1, true, 2));
    put(root / "ht_sections/v3_u8_9x9x5_sparse", ht_parts(sparse({9, 9, 5}), 1, false));
    put(root / "ht_sections/v3_u8_9x9x5_constant", ht_parts(sparse({9, 9, 5}), 1, false, 1));
    put(root / "ht_sections/v3_u16_9x5x5_linear", ht_parts(linear({9, 5, 5}), 1, false, 3));
    // Format 3.6: range-2d (mode 5) forced on the field chunks.
    put(root / "ht_sections/v3.6_u8_9x9x5_range2d", ht_parts(sample({9, 9, 5}, ValueType::U8, 4), 1, false, 5));
    put(root / "ht_sections/v3.6_i16_9x9x9_b2_range2d", ht_parts(sample({9, 9, 9}, ValueType::I16, 5), 2, false, 5));
    // Format 3.7: static (mode 6) forced on the field chunks.
    put(root / "ht_sections/v3.7_u8_9x9x5_static", ht_parts(sample({9, 9, 5}, ValueType::U8, 4), 1, false, 6));
    put(root / "ht_sections/v3.7_f64_9x9x9_b2_static", ht_parts(sample({9, 9, 9}, ValueType::F64, 5), 2, false, 6));
    // Format 3.8: range-exp (mode 7) forced on the error chunks.
    put(root / "ht_sections/v3.8_u8_9x9x5_rangeexp", ht_parts(sample({9, 9, 5}, ValueType::U8, 4), 1, false, 7));
    put(root / "ht_sections/v3.8_f32_9x9x9_b2_rangeexp", ht_parts(sample({9, 9, 9}, ValueType::F32, 5), 2, false, 7));
    // MT coding 3 (format 3.4): stored bytes (mode 0) and header + raw payload (mode 1),
    // with and without the field. (The coding-1 seeds, *_coding1_*, were written by the
    // 2.1 writer and the coding-2 ones, *_coding2_*, by the 3.0-3.3 writers; both are kept.)
    for (auto [name, d, t] : {std::tuple{"u8_5x4x3", Dims{5, 4, 3}, ValueType::U8},
                              std::tuple{"f32_4x4x4", Dims{4, 4, 4}, ValueType::F32}}) {
        const Volume v = sample(d, t, 4);
        const MtModel m = MtModel::build(v);
        for (bool with_field : {false, true}) {
            MtEncodeOptions o;
            o.include_field = with_field;
            const auto b = encode_mt(m, o);
            std::string stored = std::string(1, '\0') + std::string(b.begin(), b.end());
            put(root / "mt" / (std::string(name) + (with_field ? "_field" : "") + "_stored"), stored);
            // Mode 1 takes coding 1's raw layout (u64 length + bytes per stream):
            // the frames of coding 3 decompressed one by one.
            std::string mode1 = std::string(1, '\1') + std::string(b.begin(), b.begin() + 48);
            for (std::size_t at = 48; at < b.size();) {
                uint64_t len = 0, zs = 0;
                std::memcpy(&len, b.data() + at, 8);
                std::memcpy(&zs, b.data() + at + 8, 8);
                mode1.append(reinterpret_cast<const char*>(b.data() + at), 8);
                if (len != 0) {
                    auto raw = tlod::zstd_decompress(
                        std::span<const std::byte>(reinterpret_cast<const std::byte*>(b.data() + at + 16), zs), len);
                    mode1.append(reinterpret_cast<const char*>(raw->data()), raw->size());
                }
                at += 16 + zs;
            }
            put(root / "mt" / (std::string(name) + (with_field ? "_field" : "") + "_raw"), mode1);
        }
    }
    // METADATA.
    {
        Volume v = sample({7, 3, 2}, ValueType::I16, 5);
        v.units = "mm";
        v.spacing = {0.5, 1, 2};
        v.origin = {-1, 0, 3};
        tlod::Metadata m = tlod::metadata_for_volume(v);
        m.format_keys[tlod::kKeyConverter] = "fuzz_make_corpus";
        const auto b = tlod::serialize_metadata(m);
        put(root / "metadata/i16_7x3x2", b.data(), b.size());
        tlod::Metadata one;
        one.dims = {1, 1, 1};
        const auto e = tlod::serialize_metadata(one);
        put(root / "metadata/minimal", e.data(), e.size());
    }
    // NRRD and MetaImage: header, then "\n@@DATA@@\n" and the data file d.raw.
    std::string raw64;
    for (int i = 0; i < 64; ++i) raw64 += char(i * 3);
    const std::string sep = "\n@@DATA@@\n";
    const std::string nh = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\n";
    put(root / "nrrd/attached_raw", nh + "encoding: raw\nspacings: 0.5 1 2\n\n" + raw64);
    put(root / "nrrd/attached_gzip", nh + "encoding: gzip\nspace origin: (1,2,3)\n\n" + gzip(raw64));
    put(root / "nrrd/detached_raw", nh + "encoding: raw\nendian: big\ndata file: d.raw\nbyte skip: 0\n" + sep + raw64);
    put(root / "nrrd/detached_gzip", nh + "encoding: gzip\ndata file: d.raw\nk:=v\n" + sep + gzip(raw64));
    put(root / "nrrd/pattern",
        "NRRD0004\ntype: short\ndimension: 3\nsizes: 4 4 2\nencoding: raw\ndata file: d%d.raw 1 2 1 2\n" + sep +
            sep + raw64.substr(0, 32) + sep + raw64.substr(32));
    put(root / "nrrd/list", nh + "encoding: raw\nspace directions: (1,0,0) (0,2,0) (0,0,3)\ndata file: LIST 2\nd1.raw\nd2.raw\nd3.raw\nd4.raw\n" + sep +
                                 sep + raw64.substr(0, 16) + sep + raw64.substr(16, 16) + sep +
                                 raw64.substr(32, 16) + sep + raw64.substr(48));
    const std::string mh = "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n";
    put(root / "metaimage/local_raw", mh + "ElementSpacing = 1 2 3\nOffset = 1 2 3\nElementDataFile = LOCAL\n" + raw64);
    put(root / "metaimage/local_zlib", mh + "CompressedData = True\nElementDataFile = LOCAL\n" + gzip(raw64));
    put(root / "metaimage/detached", mh + "BinaryDataByteOrderMSB = True\nElementDataFile = d.raw\n" + sep + raw64);
    put(root / "metaimage/pattern",
        "NDims = 3\nDimSize = 4 4 2\nElementType = MET_SHORT\nElementDataFile = d%d.raw 1 2 1 2\n" + sep + sep +
            raw64.substr(0, 32) + sep + raw64.substr(32));
    std::printf("seed corpora written to %s\n", root.c_str());
    return 0;
}
