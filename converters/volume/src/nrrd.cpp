// NRRD reader and writer. Format: http://teem.sourceforge.net/nrrd/format.html
// (NRRD0005). See tetlod/converters/nrrd.hpp for what is supported and why.
#include "tetlod/converters/nrrd.hpp"

#include <algorithm>
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

struct Header {
    int version = 0;
    std::vector<std::pair<std::string, std::string>> fields;  // identifier (lower case), value
    std::vector<std::pair<std::string, std::string>> key_values;
    std::vector<std::string> list_files;  // lines after "data file: LIST"
    uint64_t data_offset = 0;             // first byte after the header
    bool ended_by_blank_line = false;
};

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
        else r += c;
    }
    return r;
}

Header read_header(const std::string& path) {
    require_regular_file(path, "NRRD header");
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) throw Error(ErrorCode::IoError, "cannot open '" + path + "': " + std::strerror(errno));
    Header h;
    std::string line;
    uint64_t pos = 0;
    bool first = true, in_list = false;
    for (;;) {
        line.clear();
        int c;
        bool got_any = false;
        while ((c = std::fgetc(f.get())) != EOF) {
            got_any = true;
            ++pos;
            if (c == '\n') break;
            line += static_cast<char>(c);
            if (pos > kMaxHeaderBytes)
                throw Error(ErrorCode::CorruptData, "'" + path + "': NRRD header longer than " +
                                                        std::to_string(kMaxHeaderBytes) + " bytes");
        }
        if (!got_any) break;  // end of file
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (first) {
            first = false;
            if (line.size() != 8 || line.compare(0, 7, "NRRD000") != 0 || line[7] < '1' || line[7] > '9')
                throw Error(ErrorCode::BadMagic, "'" + path + "' is not a NRRD file (no NRRD000x magic line)");
            h.version = line[7] - '0';
            if (h.version > 5)
                throw Error(ErrorCode::UnsupportedVersion,
                            "'" + path + "': NRRD version " + std::to_string(h.version) + " is newer than 5");
            continue;
        }
        if (line.empty()) {
            h.ended_by_blank_line = true;
            break;
        }
        if (in_list) {
            h.list_files.push_back(line);
            continue;
        }
        if (line[0] == '#') continue;
        std::size_t kv = line.find(":=");
        std::size_t fd = line.find(": ");
        if (kv != std::string::npos && (fd == std::string::npos || kv < fd)) {
            h.key_values.emplace_back(unescape(line.substr(0, kv)), unescape(line.substr(kv + 2)));
            continue;
        }
        if (fd == std::string::npos) {
            // "field:" with nothing after it is allowed only for an empty value.
            if (!line.empty() && line.back() == ':') fd = line.size() - 1;
            else
                throw Error(ErrorCode::CorruptData,
                            "'" + path + "': NRRD header line '" + line + "' is neither a field nor a key/value pair");
        }
        std::string id = to_lower(trim(line.substr(0, fd)));
        std::string value = fd + 2 <= line.size() ? trim(line.substr(fd + 2)) : std::string();
        for (const auto& [k, v] : h.fields)
            if (k == id) throw Error(ErrorCode::CorruptData, "'" + path + "': NRRD field '" + id + "' given twice");
        h.fields.emplace_back(id, value);
        if ((id == "data file" || id == "datafile")) {
            auto tok = split_ws(value);
            if (!tok.empty() && tok[0] == "LIST") in_list = true;
        }
    }
    if (first) throw Error(ErrorCode::BadMagic, "'" + path + "' is empty, not a NRRD file");
    h.data_offset = pos;
    return h;
}

const std::string* field(const Header& h, std::initializer_list<const char*> names) {
    for (const char* n : names)
        for (const auto& [k, v] : h.fields)
            if (k == n) return &v;
    return nullptr;
}

std::optional<ValueType> nrrd_type(const std::string& s, bool& is_64bit) {
    std::string t = to_lower(s);
    is_64bit = false;
    static const std::pair<const char*, ValueType> names[] = {
        {"signed char", ValueType::I8},        {"int8", ValueType::I8},
        {"int8_t", ValueType::I8},             {"uchar", ValueType::U8},
        {"unsigned char", ValueType::U8},      {"uint8", ValueType::U8},
        {"uint8_t", ValueType::U8},            {"short", ValueType::I16},
        {"short int", ValueType::I16},         {"signed short", ValueType::I16},
        {"signed short int", ValueType::I16},  {"int16", ValueType::I16},
        {"int16_t", ValueType::I16},           {"ushort", ValueType::U16},
        {"unsigned short", ValueType::U16},    {"unsigned short int", ValueType::U16},
        {"uint16", ValueType::U16},            {"uint16_t", ValueType::U16},
        {"int", ValueType::I32},               {"signed int", ValueType::I32},
        {"int32", ValueType::I32},             {"int32_t", ValueType::I32},
        {"uint", ValueType::U32},              {"unsigned int", ValueType::U32},
        {"uint32", ValueType::U32},            {"uint32_t", ValueType::U32},
        {"float", ValueType::F32},             {"double", ValueType::F64},
    };
    for (const auto& [n, v] : names)
        if (t == n) return v;
    static const char* wide[] = {"longlong", "long long", "long long int", "signed long long",
                                 "signed long long int", "int64", "int64_t", "ulonglong",
                                 "unsigned long long", "unsigned long long int", "uint64", "uint64_t"};
    for (const char* n : wide)
        if (t == n) is_64bit = true;
    return std::nullopt;
}

const char* nrrd_type_name(ValueType t) {
    switch (t) {
        case ValueType::U8: return "uint8";
        case ValueType::I8: return "int8";
        case ValueType::U16: return "uint16";
        case ValueType::I16: return "int16";
        case ValueType::U32: return "uint32";
        case ValueType::I32: return "int32";
        case ValueType::F32: return "float";
        case ValueType::F64: return "double";
    }
    return "?";
}

// "(a,b,c)" -> numbers; "none" -> empty.
std::vector<double> parse_vector(const std::string& tok, const std::string& what) {
    if (tok == "none") return {};
    if (tok.size() < 2 || tok.front() != '(' || tok.back() != ')')
        throw Error(ErrorCode::CorruptData, what + ": '" + tok + "' is not a vector like (1,0,0)");
    std::vector<double> v;
    std::string inner = tok.substr(1, tok.size() - 2);
    std::size_t b = 0;
    for (;;) {
        std::size_t e = inner.find(',', b);
        v.push_back(parse_double(trim(inner.substr(b, e == std::string::npos ? e : e - b)), what));
        if (e == std::string::npos) break;
        b = e + 1;
    }
    return v;
}

// Splits "space directions" values: vectors may contain spaces inside the parentheses.
std::vector<std::string> split_vectors(const std::string& s) {
    std::vector<std::string> out;
    std::string cur;
    int depth = 0;
    for (char c : s) {
        if (c == '(') ++depth;
        if (c == ')') --depth;
        if (std::isspace(static_cast<unsigned char>(c)) && depth == 0) {
            if (!cur.empty()) out.push_back(cur), cur.clear();
            continue;
        }
        if (!std::isspace(static_cast<unsigned char>(c))) cur += c;
    }
    if (!cur.empty()) out.push_back(cur);
    return out;
}

const std::set<std::string>& handled_fields() {
    static const std::set<std::string> s = {
        "dimension", "type", "encoding", "endian", "sizes", "spacings", "space directions",
        "space origin", "data file", "datafile", "byte skip", "byteskip", "line skip", "lineskip",
        "content", "sample units", "sampleunits", "space dimension"};
    return s;
}

std::vector<DataPiece> data_pieces(const Header& h, const std::string& path, const Dims& dims, int dimension,
                                   bool allow_external) {
    const std::string what = "'" + path + "'";
    int64_t line_skip = 0, byte_skip = 0;
    if (auto* v = field(h, {"line skip", "lineskip"})) line_skip = parse_int(*v, what + " line skip");
    if (auto* v = field(h, {"byte skip", "byteskip"})) byte_skip = parse_int(*v, what + " byte skip");
    if (line_skip < 0) throw Error(ErrorCode::CorruptData, what + ": negative line skip");
    if (byte_skip < -1) throw Error(ErrorCode::CorruptData, what + ": byte skip below -1");
    const std::string* df = field(h, {"data file", "datafile"});
    std::vector<DataPiece> pieces;
    if (!df) {
        if (!h.ended_by_blank_line)
            throw Error(ErrorCode::Truncated,
                        what + ": NRRD header has no \"data file\" field and no blank line before attached data");
        pieces.push_back({path, h.data_offset, line_skip, byte_skip});
        return pieces;
    }
    auto tok = split_ws(*df);
    int64_t subdim = -1;
    std::vector<std::string> names;
    if (!tok.empty() && tok[0] == "LIST") {
        if (tok.size() > 1) subdim = parse_int(tok[1], what + " data file subdim");
        for (const auto& n : h.list_files) names.push_back(resolve_data_file(path, n, allow_external, what));
        if (names.empty()) throw Error(ErrorCode::CorruptData, what + ": \"data file: LIST\" names no files");
    } else if (tok.size() >= 4 && tok[0].find('%') != std::string::npos) {
        int64_t lo = parse_int(tok[1], what + " data file min");
        int64_t hi = parse_int(tok[2], what + " data file max");
        int64_t step = parse_int(tok[3], what + " data file step");
        if (tok.size() > 4) subdim = parse_int(tok[4], what + " data file subdim");
        const int64_t n =
            pattern_file_count(lo, hi, step, std::min(kMaxDataFiles, dims.count()), what, "\"data file\"");
        for (int64_t i = 0; i < n; ++i)
            names.push_back(resolve_data_file(path, format_file_pattern(tok[0], lo + i * step, what),
                                              allow_external, what));
    } else {
        names.push_back(resolve_data_file(path, *df, allow_external, what));
    }
    if (subdim != -1) {
        if (subdim < 1 || subdim > dimension)
            throw Error(ErrorCode::CorruptData, what + ": data file subdim " + std::to_string(subdim) +
                                                    " outside 1.." + std::to_string(dimension));
        int64_t per = 1;
        for (int a = 0; a < subdim; ++a) per *= dims[a];
        if (per * static_cast<int64_t>(names.size()) != dims.count())
            throw Error(ErrorCode::SizeMismatch,
                        what + ": " + std::to_string(names.size()) + " data files of " + std::to_string(subdim) +
                            "-D slabs do not hold the " + std::to_string(dims.count()) + " declared samples");
    }
    for (const auto& n : names) pieces.push_back({n, 0, line_skip, byte_skip});
    return pieces;
}

}  // namespace

namespace {

/// A NRRD's header as a volume header (no samples) and where its samples are.
struct NrrdSource {
    Volume header;
    std::vector<DataPiece> pieces;
    Compression compression = Compression::None;
    Endian endian = Endian::Little;
};

NrrdSource parse_nrrd(const std::string& path, const VolumeReadOptions& options) {
    const std::string what = "'" + path + "'";
    Header h = read_header(path);

    const std::string* type_s = field(h, {"type"});
    const std::string* dim_s = field(h, {"dimension"});
    const std::string* sizes_s = field(h, {"sizes"});
    const std::string* enc_s = field(h, {"encoding"});
    if (!type_s || !dim_s || !sizes_s || !enc_s)
        throw Error(ErrorCode::CorruptData, what + ": NRRD header lacks one of the required fields "
                                                   "type, dimension, sizes, encoding");
    bool wide = false;
    auto type = nrrd_type(*type_s, wide);
    if (!type)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": NRRD type '" + *type_s + "' is not supported" +
                        (wide ? " (tetlod volumes hold at most 32-bit integers)" : ""));
    int64_t dimension = parse_int(*dim_s, what + " dimension");
    if (dimension < 1 || dimension > 3)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": NRRD dimension " + std::to_string(dimension) + " (tetlod reads 1 to 3 axes)");
    auto sizes = split_ws(*sizes_s);
    if (static_cast<int64_t>(sizes.size()) != dimension)
        throw Error(ErrorCode::CorruptData, what + ": \"sizes\" has " + std::to_string(sizes.size()) +
                                                " entries for dimension " + std::to_string(dimension));
    int64_t d[3] = {1, 1, 1};
    for (int a = 0; a < dimension; ++a) d[a] = parse_int(sizes[a], what + " sizes");
    Dims dims{d[0], d[1], d[2]};
    for (int a = 0; a < 3; ++a)  // a header's claim, not a flag: bad input data (exit 4)
        if (dims[a] < 1)
            throw Error(ErrorCode::CorruptData, what + ": \"sizes\" axis " + std::to_string(a) + " is " +
                                                    std::to_string(dims[a]) + " (must be at least 1)");
    validate_dims(dims, what);

    std::string enc = to_lower(*enc_s);
    Compression compression;
    if (enc == "raw") compression = Compression::None;
    else if (enc == "gzip" || enc == "gz") compression = Compression::Deflate;
    else
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": NRRD encoding '" + *enc_s + "' is not supported (supported: raw, gzip)");

    Endian endian = Endian::Little;
    if (auto* e = field(h, {"endian"})) {
        std::string el = to_lower(*e);
        if (el == "big") endian = Endian::Big;
        else if (el != "little")
            throw Error(ErrorCode::CorruptData, what + ": endian '" + *e + "' is neither little nor big");
    }

    // Geometry.
    Vec3 spacing{1.0, 1.0, 1.0};
    Vec3 origin{0.0, 0.0, 0.0};
    if (auto* s = field(h, {"spacings"})) {
        auto t = split_ws(*s);
        if (static_cast<int64_t>(t.size()) != dimension)
            throw Error(ErrorCode::CorruptData, what + ": \"spacings\" has " + std::to_string(t.size()) +
                                                    " entries for dimension " + std::to_string(dimension));
        for (int a = 0; a < dimension; ++a) {
            double v = parse_double(t[a], what + " spacings");
            if (std::isfinite(v) && v != 0) spacing[a] = std::fabs(v);
        }
    }
    if (auto* s = field(h, {"space directions"})) {
        auto t = split_vectors(*s);
        if (static_cast<int64_t>(t.size()) != dimension)
            throw Error(ErrorCode::CorruptData, what + ": \"space directions\" has " + std::to_string(t.size()) +
                                                    " entries for dimension " + std::to_string(dimension));
        for (int a = 0; a < dimension; ++a) {
            auto v = parse_vector(t[a], what + " space directions");
            if (v.empty()) continue;  // "none": a non-spatial axis
            bool aligned = a < static_cast<int>(v.size()) && v[a] > 0 && std::isfinite(v[a]);
            for (int c = 0; c < static_cast<int>(v.size()); ++c)
                if (c != a && v[c] != 0) aligned = false;
            if (!aligned)
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": NRRD \"space directions\" " + *s +
                                " is not an axis-aligned frame with positive steps; tetlod grids are axis-aligned "
                                "(rotated, permuted or flipped frames are not supported)");
            spacing[a] = v[a];
        }
    }
    if (auto* s = field(h, {"space origin"})) {
        auto v = parse_vector(trim(*s), what + " space origin");
        for (std::size_t c = 0; c < v.size() && c < 3; ++c)
            if (std::isfinite(v[c])) origin[c] = v[c];
    }

    NrrdSource src;
    src.pieces = data_pieces(h, path, dims, static_cast<int>(dimension), options.allow_external_data);
    src.compression = compression;
    src.endian = endian;
    Volume& vol = src.header;
    vol.dims = dims;
    vol.type = *type;
    vol.spacing = options.spacing.value_or(spacing);
    vol.origin = options.origin.value_or(origin);
    check_geometry(vol.spacing, vol.origin, what);
    if (auto* c = field(h, {"content"}); c && !c->empty()) vol.field_name = *c;
    if (auto* u = field(h, {"sample units", "sampleunits"})) vol.units = *u;
    for (const auto& [k, v] : h.fields)
        if (!handled_fields().count(k)) vol.metadata["nrrd:" + k] = v;
    for (const auto& [k, v] : h.key_values) vol.metadata[k] = v;
    return src;
}

}  // namespace

Volume read_nrrd(const std::string& path, const VolumeReadOptions& options) {
    NrrdSource src = parse_nrrd(path, options);
    const Volume& h = src.header;
    Volume vol = read_samples(h.dims, h.type, src.pieces, src.compression, src.endian, "'" + path + "'");
    vol.spacing = h.spacing;
    vol.origin = h.origin;
    vol.field_name = h.field_name;
    vol.units = h.units;
    vol.metadata = h.metadata;
    return vol;
}

std::unique_ptr<VolumePlanes> open_nrrd_planes(const std::string& path, const VolumeReadOptions& options) {
    NrrdSource src = parse_nrrd(path, options);
    return planes_of_pieces(std::move(src.header), src.pieces, src.compression, src.endian, "'" + path + "'");
}

namespace {

bool is_3d_space(const std::string& s) {
    static const std::set<std::string> names = {
        "right-anterior-superior", "ras", "left-anterior-superior", "las", "left-posterior-superior",
        "lps", "scanner-xyz", "3d-right-handed", "3d-left-handed"};
    return names.count(to_lower(s)) != 0;
}

std::string one_line(const std::string& s) {
    std::string r = s;
    std::replace(r.begin(), r.end(), '\n', ' ');
    std::replace(r.begin(), r.end(), '\r', ' ');
    return r;
}

}  // namespace

namespace {

// A NRRD key/value line is "key:=value": the key cannot be empty, hold ":="
// or break the line.
bool nrrd_can_hold_key(const std::string& k) {
    return !k.empty() && k.find(":=") == std::string::npos && k.find('\n') == std::string::npos &&
           k.find('\r') == std::string::npos;
}

}  // namespace

std::vector<std::string> nrrd_unstorable_keys(const Volume& vol) {
    std::vector<std::string> out;
    for (const auto& [k, v] : vol.metadata)
        if (!nrrd_can_hold_key(k)) out.push_back(k);
    return out;
}

void write_nrrd(const Volume& vol, const std::string& path, const NrrdWriteOptions& options) {
    if (vol.data.size() != static_cast<std::size_t>(vol.dims.count()) * value_size(vol.type))
        throw Error(ErrorCode::InvalidArgument, "'" + path + "': volume data size does not match its dims");
    auto planes = planes_of(vol);
    write_nrrd(*planes, path, options);
}

void write_nrrd(VolumePlanes& planes, const std::string& path, const NrrdWriteOptions& options) {
    const Volume& vol = planes.header();
    validate_dims(vol.dims, "'" + path + "'");
    bool detached = options.layout == NrrdWriteOptions::Layout::Detached ||
                    (options.layout == NrrdWriteOptions::Layout::Auto &&
                     to_lower(std::filesystem::path(path).extension().string()) == ".nhdr");

    std::string hdr = "NRRD0004\n# Written by tetlod " TETLOD_VERSION_STRING "\n";
    hdr += std::string("type: ") + nrrd_type_name(vol.type) + "\n";
    hdr += "dimension: 3\n";
    auto meta = [&](const char* k) -> const std::string* {
        auto it = vol.metadata.find(k);
        return it == vol.metadata.end() ? nullptr : &it->second;
    };
    const std::string* space = meta("nrrd:space");
    if (space && is_3d_space(*space)) hdr += "space: " + one_line(*space) + "\n";
    else hdr += "space dimension: 3\n";
    hdr += "sizes: " + std::to_string(vol.dims.x) + " " + std::to_string(vol.dims.y) + " " +
           std::to_string(vol.dims.z) + "\n";
    const Vec3& s = vol.spacing;
    hdr += "space directions: (" + format_double(s[0]) + ",0,0) (0," + format_double(s[1]) + ",0) (0,0," +
           format_double(s[2]) + ")\n";
    hdr += "space origin: (" + format_double(vol.origin[0]) + "," + format_double(vol.origin[1]) + "," +
           format_double(vol.origin[2]) + ")\n";
    // Informative per-axis fields read from a NRRD go back as fields when they
    // still describe three axes; otherwise they stay key/value pairs.
    std::set<std::string> written_native;
    if (space && is_3d_space(*space)) written_native.insert("nrrd:space");
    for (const char* f : {"kinds", "centers", "space units"}) {
        const std::string key = std::string("nrrd:") + f;
        const std::string* v = meta(key.c_str());
        if (v && split_ws(*v).size() == 3) {
            hdr += std::string(f) + ": " + one_line(*v) + "\n";
            written_native.insert(key);
        }
    }
    if (value_size(vol.type) > 1)
        hdr += std::string("endian: ") + (options.endian == Endian::Big ? "big" : "little") + "\n";
    hdr += std::string("encoding: ") + (options.gzip ? "gzip" : "raw") + "\n";
    if (!vol.field_name.empty()) hdr += "content: " + one_line(vol.field_name) + "\n";
    if (!vol.units.empty()) hdr += "sample units: " + one_line(vol.units) + "\n";
    for (const auto& [k, v] : vol.metadata) {
        if (written_native.count(k) || !nrrd_can_hold_key(k)) continue;  // see nrrd_unstorable_keys()
        hdr += escape(k) + ":=" + escape(v) + "\n";
    }
    Compression comp = options.gzip ? Compression::Deflate : Compression::None;
    if (detached && is_std_stream(path))
        throw Error(ErrorCode::InvalidArgument,
                    "a detached NRRD header cannot be written to standard output ('-'): its data "
                    "file needs a name; give a file name or the attached format");
    if (detached) {
        std::filesystem::path p(path);
        std::string data_name = p.stem().string() + (options.gzip ? ".raw.gz" : ".raw");
        std::string data_path = (p.parent_path() / data_name).string();
        // Both files pass the output policy before a sample is written.
        AtomicFile data(data_path);
        AtomicFile header(path);
        write_samples(data, planes, options.endian, comp, true);
        hdr += "data file: " + data_name + "\n";
        header.write(hdr);
        data.commit();
        header.commit();
    } else {
        AtomicFile out(path);
        hdr += "\n";
        out.write(hdr);
        write_samples(out, planes, options.endian, comp, true);
        out.commit();
    }
}

}  // namespace tetlod
