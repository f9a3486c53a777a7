// MetaImage (.mha/.mhd) reader and writer. Field reference: ITK MetaIO
// documentation. See tetlod/converters/metaimage.hpp for what is supported.
#include "tetlod/converters/metaimage.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <set>

#include "nrrd_metaimage_common.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/regular_file.hpp"
#include "tetlod/core/output_policy.hpp"

namespace tetlod {

using namespace detail;

namespace {

constexpr std::size_t kMaxHeaderBytes = std::size_t{1} << 20;
constexpr int64_t kMaxDataFiles = int64_t{1} << 20;

struct Field {
    std::string key;    // as written
    std::string lower;  // lower case, for matching
    std::string value;
};

struct Header {
    std::vector<Field> fields;
    std::vector<std::string> list_files;
    uint64_t data_offset = 0;
    bool has_data_file = false;
};

// Fields the reader interprets (lower case); everything else is metadata.
const std::set<std::string>& structural_fields() {
    static const std::set<std::string> s = {
        "objecttype", "ndims", "dimsize", "elementtype", "elementspacing", "elementsize", "offset",
        "position", "origin", "transformmatrix", "rotation", "orientation", "binarydata",
        "binarydatabyteordermsb", "elementbyteordermsb", "compresseddata", "compresseddatasize",
        "headersize", "elementnumberofchannels", "elementdatafile", "name", "units"};
    return s;
}

std::string unescape(const std::string& s) {
    std::string r;
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '\\' && i + 1 < s.size() && (s[i + 1] == 'n' || s[i + 1] == '\\')) {
            r += s[i + 1] == 'n' ? '\n' : '\\';
            ++i;
        } else {
            r += s[i];
        }
    }
    return r;
}

std::string escape(const std::string& s) {
    std::string r;
    for (char c : s) {
        if (c == '\\') r += "\\\\";
        else if (c == '\n') r += "\\n";
        else if (c != '\r') r += c;
    }
    return r;
}

Header read_header(const std::string& path) {
    require_regular_file(path, "MetaImage header");
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + std::strerror(errno));
    Header h;
    uint64_t pos = 0;
    bool in_list = false;
    std::string line;
    for (;;) {
        line.clear();
        int c;
        bool got = false;
        while ((c = std::fgetc(f.get())) != EOF) {
            got = true;
            ++pos;
            if (c == '\n') break;
            if (c == '\0' && !in_list)
                throw Error(ErrorCode::BadMagic, "'" + path + "' is not a MetaImage header (binary bytes before "
                                                              "ElementDataFile)");
            line += static_cast<char>(c);
            if (pos > kMaxHeaderBytes)
                throw Error(ErrorCode::CorruptData, "'" + path + "': MetaImage header longer than " +
                                                        std::to_string(kMaxHeaderBytes) + " bytes");
        }
        if (!got) break;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (in_list) {
            std::string t = trim(line);
            if (!t.empty()) h.list_files.push_back(t);
            continue;
        }
        if (trim(line).empty()) continue;
        std::size_t eq = line.find('=');
        if (eq == std::string::npos)
            throw Error(ErrorCode::CorruptData,
                        "'" + path + "': MetaImage header line '" + line + "' is not \"Key = Value\"");
        Field fl{trim(line.substr(0, eq)), "", trim(line.substr(eq + 1))};
        fl.lower = to_lower(fl.key);
        if (fl.key.empty())
            throw Error(ErrorCode::CorruptData, "'" + path + "': MetaImage header line '" + line + "' has no key");
        h.fields.push_back(fl);
        if (fl.lower == "elementdatafile") {
            h.has_data_file = true;
            auto tok = split_ws(fl.value);
            if (!tok.empty() && to_lower(tok[0]) == "list") {
                in_list = true;
                continue;
            }
            break;  // ElementDataFile ends the header
        }
    }
    if (!h.has_data_file)
        throw Error(ErrorCode::CorruptData, "'" + path + "': MetaImage header has no ElementDataFile field");
    h.data_offset = pos;
    return h;
}

const std::string* field(const Header& h, std::initializer_list<const char*> names) {
    for (const char* n : names)
        for (const auto& f : h.fields)
            if (f.lower == n) return &f.value;
    return nullptr;
}

bool parse_bool(const std::string& v, const std::string& what) {
    std::string l = to_lower(v);
    if (l == "true" || l == "1") return true;
    if (l == "false" || l == "0") return false;
    throw Error(ErrorCode::CorruptData, what + ": '" + v + "' is neither True nor False");
}

std::optional<ValueType> met_type(const std::string& s) {
    static const std::pair<const char*, ValueType> names[] = {
        {"MET_CHAR", ValueType::I8},   {"MET_UCHAR", ValueType::U8},   {"MET_SHORT", ValueType::I16},
        {"MET_USHORT", ValueType::U16}, {"MET_INT", ValueType::I32},   {"MET_UINT", ValueType::U32},
        {"MET_LONG", ValueType::I32},  {"MET_ULONG", ValueType::U32},  {"MET_FLOAT", ValueType::F32},
        {"MET_DOUBLE", ValueType::F64}};
    for (const auto& [n, t] : names)
        if (s == n) return t;
    return std::nullopt;
}

const char* met_type_name(ValueType t) {
    switch (t) {
        case ValueType::U8: return "MET_UCHAR";
        case ValueType::I8: return "MET_CHAR";
        case ValueType::U16: return "MET_USHORT";
        case ValueType::I16: return "MET_SHORT";
        case ValueType::U32: return "MET_UINT";
        case ValueType::I32: return "MET_INT";
        case ValueType::F32: return "MET_FLOAT";
        case ValueType::F64: return "MET_DOUBLE";
    }
    return "?";
}

std::vector<double> numbers(const std::string& v, std::size_t n, const std::string& what) {
    auto t = split_ws(v);
    if (t.size() != n)
        throw Error(ErrorCode::CorruptData,
                    what + ": expected " + std::to_string(n) + " numbers, got '" + v + "'");
    std::vector<double> r;
    for (const auto& s : t) r.push_back(parse_double(s, what));
    return r;
}

}  // namespace

namespace {

/// A MetaImage's header as a volume header (no samples) and where its samples are.
struct MetaImageSource {
    Volume header;
    std::vector<DataPiece> pieces;
    Compression compression = Compression::None;
    Endian endian = Endian::Little;
};

MetaImageSource parse_metaimage(const std::string& path, const VolumeReadOptions& options) {
    const std::string what = "'" + path + "'";
    Header h = read_header(path);

    const std::string* ndims_s = field(h, {"ndims"});
    const std::string* dimsize_s = field(h, {"dimsize"});
    const std::string* type_s = field(h, {"elementtype"});
    if (!ndims_s || !dimsize_s || !type_s)
        throw Error(ErrorCode::CorruptData,
                    what + ": MetaImage header lacks one of NDims, DimSize, ElementType");
    int64_t nd = parse_int(*ndims_s, what + " NDims");
    if (nd < 1 || nd > 3)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": MetaImage NDims " + std::to_string(nd) + " (tetlod reads 1 to 3 axes)");
    const std::size_t n = static_cast<std::size_t>(nd);
    auto ds = split_ws(*dimsize_s);
    if (ds.size() != n)
        throw Error(ErrorCode::CorruptData, what + ": DimSize has " + std::to_string(ds.size()) +
                                                " entries for NDims " + std::to_string(nd));
    int64_t d[3] = {1, 1, 1};
    for (std::size_t a = 0; a < n; ++a) d[a] = parse_int(ds[a], what + " DimSize");
    Dims dims{d[0], d[1], d[2]};
    validate_dims(dims, what);
    auto type = met_type(*type_s);
    if (!type)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": MetaImage ElementType '" + *type_s + "' is not supported" +
                        (type_s->find("LONG_LONG") != std::string::npos
                             ? " (tetlod volumes hold at most 32-bit integers)"
                             : ""));
    if (auto* c = field(h, {"elementnumberofchannels"}); c && parse_int(*c, what + " ElementNumberOfChannels") != 1)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": ElementNumberOfChannels = " + *c + " (tetlod reads scalar volumes only)");
    if (auto* b = field(h, {"binarydata"}); b && !parse_bool(*b, what + " BinaryData"))
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": ASCII MetaImage data (BinaryData = False) is not supported");

    Endian endian = Endian::Little;
    if (auto* m = field(h, {"binarydatabyteordermsb", "elementbyteordermsb"}))
        endian = parse_bool(*m, what + " BinaryDataByteOrderMSB") ? Endian::Big : Endian::Little;
    Compression compression = Compression::None;
    if (auto* c = field(h, {"compresseddata"}); c && parse_bool(*c, what + " CompressedData"))
        compression = Compression::Deflate;

    Vec3 spacing{1.0, 1.0, 1.0}, origin{0.0, 0.0, 0.0};
    if (auto* s = field(h, {"elementspacing", "elementsize"})) {
        auto v = numbers(*s, n, what + " ElementSpacing");
        for (std::size_t a = 0; a < n; ++a) {
            // A container cannot hold a non-finite geometry: refuse it here.
            if (!std::isfinite(v[a]))
                throw Error(ErrorCode::CorruptData, what + ": ElementSpacing '" + *s + "' is not finite");
            if (v[a] != 0) spacing[a] = std::fabs(v[a]);
        }
    }
    if (auto* s = field(h, {"offset", "position", "origin"})) {
        auto v = numbers(*s, n, what + " Offset");
        for (std::size_t a = 0; a < n; ++a) {
            if (!std::isfinite(v[a]))
                throw Error(ErrorCode::CorruptData, what + ": Offset '" + *s + "' is not finite");
            origin[a] = v[a];
        }
    }
    if (auto* s = field(h, {"transformmatrix", "rotation", "orientation"})) {
        auto v = numbers(*s, n * n, what + " TransformMatrix");
        for (std::size_t r = 0; r < n; ++r)
            for (std::size_t c = 0; c < n; ++c)
                if (v[r * n + c] != (r == c ? 1.0 : 0.0))
                    throw Error(ErrorCode::UnsupportedFeature,
                                what + ": TransformMatrix " + *s +
                                    " is not the identity; tetlod grids are axis-aligned (rotated or flipped "
                                    "frames are not supported)");
    }

    int64_t header_size = 0;
    if (auto* s = field(h, {"headersize"})) header_size = parse_int(*s, what + " HeaderSize");
    if (header_size < -1) throw Error(ErrorCode::CorruptData, what + ": HeaderSize below -1");
    if (header_size == -1 && compression != Compression::None)
        throw Error(ErrorCode::UnsupportedFeature, what + ": HeaderSize = -1 with compressed data");

    std::vector<DataPiece> pieces;
    const std::string& df = *field(h, {"elementdatafile"});
    auto tok = split_ws(df);
    int64_t subdim = -1;
    std::vector<std::string> names;
    if (df == "LOCAL") {
        pieces.push_back({path, h.data_offset, 0, header_size});
    } else if (!tok.empty() && to_lower(tok[0]) == "list") {
        if (tok.size() > 1) subdim = parse_int(tok[1], what + " ElementDataFile subdim");
        for (const auto& nm : h.list_files)
            names.push_back(resolve_data_file(path, nm, options.allow_external_data, what));
        if (names.empty()) throw Error(ErrorCode::CorruptData, what + ": ElementDataFile = LIST names no files");
    } else if (tok.size() >= 4 && tok[0].find('%') != std::string::npos) {
        int64_t lo = parse_int(tok[1], what + " ElementDataFile min");
        int64_t hi = parse_int(tok[2], what + " ElementDataFile max");
        int64_t step = parse_int(tok[3], what + " ElementDataFile step");
        if (tok.size() > 4) subdim = parse_int(tok[4], what + " ElementDataFile subdim");
        const int64_t count =
            pattern_file_count(lo, hi, step, std::min(kMaxDataFiles, dims.count()), what, "ElementDataFile");
        for (int64_t i = 0; i < count; ++i)
            names.push_back(resolve_data_file(path, format_file_pattern(tok[0], lo + i * step, what),
                                              options.allow_external_data, what));
    } else {
        if (df.empty()) throw Error(ErrorCode::CorruptData, what + ": empty ElementDataFile");
        names.push_back(resolve_data_file(path, df, options.allow_external_data, what));
    }
    if (subdim != -1) {
        if (subdim < 1 || subdim > nd)
            throw Error(ErrorCode::CorruptData, what + ": ElementDataFile subdim out of range");
        int64_t per = 1;
        for (int a = 0; a < subdim; ++a) per *= dims[a];
        if (per * static_cast<int64_t>(names.size()) != dims.count())
            throw Error(ErrorCode::SizeMismatch, what + ": " + std::to_string(names.size()) +
                                                     " data files do not hold the declared samples");
    }
    for (const auto& nm : names)
        // MetaIO applies HeaderSize to each data file.
        pieces.push_back({nm, 0, 0, header_size});

    MetaImageSource src;
    src.pieces = std::move(pieces);
    src.compression = compression;
    src.endian = endian;
    Volume& vol = src.header;
    vol.dims = dims;
    vol.type = *type;
    vol.spacing = options.spacing.value_or(spacing);
    vol.origin = options.origin.value_or(origin);
    check_geometry(vol.spacing, vol.origin, what);
    if (auto* nm = field(h, {"name"}); nm && !nm->empty()) vol.field_name = unescape(*nm);
    if (auto* u = field(h, {"units"})) vol.units = unescape(*u);
    for (const auto& f : h.fields)
        if (!structural_fields().count(f.lower)) vol.metadata[f.key] = unescape(f.value);
    return src;
}

}  // namespace

Volume read_metaimage(const std::string& path, const VolumeReadOptions& options) {
    MetaImageSource src = parse_metaimage(path, options);
    const Volume& h = src.header;
    Volume vol = read_samples(h.dims, h.type, src.pieces, src.compression, src.endian, "'" + path + "'");
    vol.spacing = h.spacing;
    vol.origin = h.origin;
    vol.field_name = h.field_name;
    vol.units = h.units;
    vol.metadata = h.metadata;
    return vol;
}

std::unique_ptr<VolumePlanes> open_metaimage_planes(const std::string& path, const VolumeReadOptions& options) {
    MetaImageSource src = parse_metaimage(path, options);
    return planes_of_pieces(std::move(src.header), src.pieces, src.compression, src.endian, "'" + path + "'");
}

namespace {

// A MetaImage line is "Key = value": a key with '=' or white space would not
// read back, and a MetaIO field name would be taken for that field.
bool metaimage_can_hold_key(const std::string& k) {
    if (k.empty() || structural_fields().count(to_lower(k))) return false;
    for (char c : k)
        if (c == '=' || std::isspace(static_cast<unsigned char>(c))) return false;
    return true;
}

}  // namespace

std::vector<std::string> metaimage_unstorable_keys(const Volume& vol) {
    std::vector<std::string> out;
    for (const auto& [k, v] : vol.metadata)
        if (!metaimage_can_hold_key(k)) out.push_back(k);
    return out;
}

void write_metaimage(const Volume& vol, const std::string& path, const MetaImageWriteOptions& options) {
    if (vol.data.size() != static_cast<std::size_t>(vol.dims.count()) * value_size(vol.type))
        throw Error(ErrorCode::InvalidArgument, "'" + path + "': volume data size does not match its dims");
    auto planes = planes_of(vol);
    write_metaimage(*planes, path, options);
}

void write_metaimage(VolumePlanes& planes, const std::string& path, const MetaImageWriteOptions& options) {
    const Volume& vol = planes.header();
    const std::string what = "'" + path + "'";
    validate_dims(vol.dims, what);
    const bool detached = options.layout == MetaImageWriteOptions::Layout::Detached ||
                          (options.layout == MetaImageWriteOptions::Layout::Auto &&
                           to_lower(std::filesystem::path(path).extension().string()) == ".mhd");
    const Compression comp = options.compress ? Compression::Deflate : Compression::None;
    auto fmt3 = [](const Vec3& v) {
        return format_double(v[0]) + " " + format_double(v[1]) + " " + format_double(v[2]);
    };
    std::string hdr = "ObjectType = Image\nNDims = 3\nBinaryData = True\n";
    hdr += std::string("BinaryDataByteOrderMSB = ") + (options.endian == Endian::Big ? "True" : "False") + "\n";
    hdr += std::string("CompressedData = ") + (options.compress ? "True" : "False") + "\n";
    auto tail = [&](std::string h) {
        h += "TransformMatrix = 1 0 0 0 1 0 0 0 1\n";
        h += "Offset = " + fmt3(vol.origin) + "\n";
        h += "ElementSpacing = " + fmt3(vol.spacing) + "\n";
        h += "DimSize = " + std::to_string(vol.dims.x) + " " + std::to_string(vol.dims.y) + " " +
             std::to_string(vol.dims.z) + "\n";
        if (!vol.field_name.empty()) h += "Name = " + escape(vol.field_name) + "\n";
        if (!vol.units.empty()) h += "units = " + escape(vol.units) + "\n";
        for (const auto& [k, v] : vol.metadata)  // the others: metaimage_unstorable_keys()
            if (metaimage_can_hold_key(k)) h += k + " = " + escape(v) + "\n";
        h += std::string("ElementType = ") + met_type_name(vol.type) + "\n";
        return h;
    };
    if (detached && is_std_stream(path))
        throw Error(ErrorCode::InvalidArgument,
                    "a detached MetaImage header cannot be written to standard output ('-'): its data "
                    "file needs a name; give a file name or the attached format");
    if (detached) {
        std::filesystem::path p(path);
        std::string data_name = p.stem().string() + (options.compress ? ".zraw" : ".raw");
        // Both files pass the output policy before a sample is written.
        AtomicFile data((p.parent_path() / data_name).string());
        AtomicFile header(path);
        uint64_t bytes = write_samples(data, planes, options.endian, comp, false);
        if (options.compress) hdr += "CompressedDataSize = " + std::to_string(bytes) + "\n";
        hdr = tail(hdr) + "ElementDataFile = " + data_name + "\n";
        header.write(hdr);
        data.commit();
        header.commit();
    } else {
        // CompressedDataSize is optional; with LOCAL data the reader takes the rest of the file.
        hdr = tail(hdr) + "ElementDataFile = LOCAL\n";
        AtomicFile out(path);
        out.write(hdr);
        write_samples(out, planes, options.endian, comp, false);
        out.commit();
    }
}

}  // namespace tetlod
