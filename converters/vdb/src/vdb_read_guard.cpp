#include "vdb_read_guard.hpp"

#include <charconv>
#include <cstring>
#include <fstream>
#include <set>

#include "tetlod/core/error.hpp"

namespace tetlod::vdb_guard {

namespace {

constexpr int64_t kVdbMagic = 0x56444220;
constexpr uint32_t kOldestVersion = 211;  // library version numbers in the header
constexpr uint32_t kNewestVersion = 224;  // OpenVDB 10's OPENVDB_FILE_VERSION
constexpr std::size_t kKeptMetaBytes = 4096;

// Bounded little-endian reads from [pos, end) of the file.
class Cursor {
public:
    Cursor(std::ifstream& in, uint64_t pos, uint64_t end, const std::string& what)
        : in_(in), pos_(pos), end_(end), what_(what) {}
    uint64_t pos() const { return pos_; }
    uint64_t left() const { return end_ - pos_; }
    void need(uint64_t n, const std::string& field) const {
        if (n > left())
            throw Error(ErrorCode::CorruptData, what_ + ": " + field + " claims " + std::to_string(n) +
                                                    " bytes where " + std::to_string(left()) +
                                                    " remain: the file is corrupt or truncated");
    }
    void bytes(void* out, uint64_t n, const std::string& field) {
        need(n, field);
        in_.clear();
        in_.seekg(static_cast<std::streamoff>(pos_));
        in_.read(static_cast<char*>(out), static_cast<std::streamsize>(n));
        if (static_cast<uint64_t>(in_.gcount()) != n)
            throw Error(ErrorCode::Truncated, what_ + ": the file ends inside " + field);
        pos_ += n;
    }
    template <class T>
    T get(const std::string& field) {
        T v;
        bytes(&v, sizeof v, field);
        return v;
    }
    std::string str(const std::string& field, uint64_t max_bytes) {
        const uint32_t n = get<uint32_t>(field + " length");
        if (n > max_bytes)
            throw Error(ErrorCode::CorruptData, what_ + ": " + field + " of " + std::to_string(n) +
                                                    " bytes (at most " + std::to_string(max_bytes) +
                                                    " expected): the file is corrupt");
        std::string s(n, '\0');
        bytes(s.data(), n, field);
        return s;
    }
    void skip(uint64_t n, const std::string& field) {
        need(n, field);
        pos_ += n;
    }

private:
    std::ifstream& in_;
    uint64_t pos_, end_;
    const std::string& what_;
};

// MetaMap: count, then (name, type name, byte size, bytes) per entry.
std::map<std::string, std::pair<std::string, std::string>> read_meta_map(Cursor& c, const std::string& whose) {
    std::map<std::string, std::pair<std::string, std::string>> kept;
    const uint32_t count = c.get<uint32_t>(whose + " metadata count");
    // Each entry needs at least 12 bytes (three lengths).
    c.need(uint64_t{count} * 12, whose + " metadata (" + std::to_string(count) + " entries)");
    for (uint32_t i = 0; i < count; ++i) {
        std::string name = c.str(whose + " metadata name", 1 << 16);
        std::string type = c.str(whose + " metadata type of '" + name + "'", 256);
        const uint32_t size = c.get<uint32_t>(whose + " metadata '" + name + "' size");
        if (size <= kKeptMetaBytes) {
            std::string raw(size, '\0');
            c.bytes(raw.data(), size, whose + " metadata '" + name + "'");
            kept[name] = {type, std::move(raw)};
        } else {
            c.skip(size, whose + " metadata '" + name + "'");
        }
    }
    return kept;
}

const std::set<std::string>& transform_names() {
    static const std::set<std::string> s = {"AffineMap",         "UnitaryMap",        "ScaleMap",
                                            "UniformScaleMap",   "TranslationMap",    "ScaleTranslateMap",
                                            "UniformScaleTranslateMap", "NonlinearFrustumMap"};
    return s;
}

}  // namespace

VdbLayout check_vdb_layout(const std::string& file, uint64_t file_size) {
    const std::string what = "'" + file + "'";
    std::ifstream in(file, std::ios::binary);
    if (!in) throw Error(ErrorCode::IoError, "cannot open " + what);
    VdbLayout layout;
    Cursor c(in, 0, file_size, what);
    if (file_size < 8 || c.get<int64_t>("magic") != kVdbMagic)
        throw Error(ErrorCode::BadMagic, what + " is not an OpenVDB file (no VDB magic number)");
    const uint32_t v = c.get<uint32_t>("file version");
    layout.version = v;
    if (v < kOldestVersion || v > kNewestVersion)
        throw Error(ErrorCode::UnsupportedVersion, what + ": VDB file format version " + std::to_string(v) +
                                                       " (this OpenVDB reads " + std::to_string(kOldestVersion) +
                                                       " to " + std::to_string(kNewestVersion) + ")");
    c.skip(8, "library version");
    const uint8_t has_offsets = c.get<uint8_t>("grid offsets flag");
    if (v >= 220 && v < 222) c.skip(1, "compression flag");
    c.skip(v >= 218 ? 36 : 16, "file UUID");
    read_meta_map(c, "file");
    if (!has_offsets)
        throw Error(ErrorCode::UnsupportedFeature, what + ": a VDB stream without grid offsets; tetlod reads VDB files");
    const int32_t grids = c.get<int32_t>("grid count");
    if (grids < 0 || uint64_t(grids) * 36 > c.left())
        throw Error(ErrorCode::CorruptData,
                    what + ": " + std::to_string(grids) + " grids declared in " + std::to_string(c.left()) +
                        " bytes: the file is corrupt");
    uint64_t at = c.pos();
    for (int32_t g = 0; g < grids; ++g) {
        Cursor d(in, at, file_size, what);
        GridEntry e;
        std::string unique = d.str("grid name", 1 << 16);
        e.name = unique.substr(0, unique.find('\x1e'));  // OpenVDB's unique-name separator
        e.tree_type = d.str("grid type of '" + e.name + "'", 256);
        if (const std::string half = "_HalfFloat";
            e.tree_type.size() > half.size() && e.tree_type.compare(e.tree_type.size() - half.size(), half.size(), half) == 0)
            e.tree_type.resize(e.tree_type.size() - half.size());
        if (v >= 216) d.str("instance parent of '" + e.name + "'", 1 << 16);
        const int64_t gp = d.get<int64_t>("grid offset"), bp = d.get<int64_t>("block offset"),
                      ep = d.get<int64_t>("end offset");
        if (!(int64_t(d.pos()) <= gp && gp <= bp && bp <= ep && uint64_t(ep) <= file_size))
            throw Error(ErrorCode::CorruptData, what + ": grid '" + e.name + "' has offsets " + std::to_string(gp) +
                                                    ", " + std::to_string(bp) + ", " + std::to_string(ep) +
                                                    " outside the " + std::to_string(file_size) +
                                                    "-byte file or out of order: the file is corrupt");
        e.grid_pos = uint64_t(gp);
        e.block_pos = uint64_t(bp);
        e.end_pos = uint64_t(ep);
        if (v >= 222) {
            Cursor m(in, e.grid_pos, e.block_pos, what);
            const uint32_t compression = m.get<uint32_t>("compression flags of '" + e.name + "'");
            if (compression > 7)
                throw Error(ErrorCode::CorruptData, what + ": grid '" + e.name + "' has unknown compression flags " +
                                                        std::to_string(compression) + ": the file is corrupt");
            e.meta = read_meta_map(m, "grid '" + e.name + "'");
            const std::string map = m.str("transform type of '" + e.name + "'", 64);
            if (!transform_names().count(map))
                throw Error(ErrorCode::CorruptData,
                            what + ": grid '" + e.name + "' has an unknown transform type: the file is corrupt");
        }
        layout.grids.push_back(std::move(e));
        // The next descriptor follows this grid; offsets only grow, so this ends.
        at = uint64_t(ep);
        if (g + 1 < grids && at <= layout.grids.back().grid_pos)
            throw Error(ErrorCode::CorruptData, what + ": grid offsets do not advance: the file is corrupt");
    }
    return layout;
}

std::string value_type_of_tree(const std::string& tree_type) {
    const std::string prefix = "Tree_";
    if (tree_type.compare(0, prefix.size(), prefix) != 0) return "";
    const std::size_t end = tree_type.find('_', prefix.size());
    return tree_type.substr(prefix.size(), end == std::string::npos ? std::string::npos : end - prefix.size());
}

std::size_t dense_value_bytes(const std::string& t) {
    if (t == "float" || t == "int32") return 4;
    if (t == "double" || t == "int64") return 8;  // int64 is staged as double
    if (t == "bool") return 1;
    return 0;
}

Dims parse_dims_xyz(const std::string& type_name, const std::string& raw, const std::string& what) {
    int64_t n[3] = {0, 0, 0};
    bool ok = false;
    if (type_name == "vec3i" && raw.size() == 12) {
        for (int a = 0; a < 3; ++a) {
            int32_t x;
            std::memcpy(&x, raw.data() + 4 * a, 4);
            n[a] = x;
        }
        ok = true;
    } else if (type_name == "string") {
        // Exactly three integers separated by spaces, commas or brackets.
        int found = 0;
        const char* p = raw.data();
        const char* end = p + raw.size();
        ok = true;
        while (p < end && ok) {
            if (*p == ' ' || *p == ',' || *p == '[' || *p == ']' || *p == '(' || *p == ')') {
                ++p;
                continue;
            }
            int64_t x = 0;
            auto r = std::from_chars(p, end, x);
            if (r.ec != std::errc() || found == 3) {
                ok = false;
                break;
            }
            n[found++] = x;
            p = r.ptr;
        }
        ok = ok && found == 3;
    }
    if (ok)
        for (int64_t x : n) ok = ok && x > 0;
    if (!ok) {
        std::string shown = type_name == "string" ? "'" + raw.substr(0, 64) + "'" : "of type " + type_name;
        throw Error(ErrorCode::CorruptData,
                    what + ": metadata dims_xyz " + shown + " is not three positive integers: the file is corrupt");
    }
    if (n[0] > kMaxAxisSize || n[1] > kMaxAxisSize || n[2] > kMaxAxisSize)
        throw Error(ErrorCode::TooLarge, what + ": metadata dims_xyz " + std::to_string(n[0]) + " " +
                                             std::to_string(n[1]) + " " + std::to_string(n[2]) +
                                             " exceeds the largest axis tetlod reads (" + std::to_string(kMaxAxisSize) +
                                             ")");
    return Dims{n[0], n[1], n[2]};
}

void check_dense_bound(const Dims& dims, std::size_t value_bytes, uint64_t file_size, const std::string& what,
                       const std::string& source) {
    const double dense = static_cast<double>(dims.x) * static_cast<double>(dims.y) * static_cast<double>(dims.z) *
                         static_cast<double>(value_bytes);
    const double bound = static_cast<double>(file_size) * static_cast<double>(kMaxDenseExpansion) +
                         static_cast<double>(kDenseAllowanceBytes);
    if (dense > bound)
        throw Error(ErrorCode::TooLarge,
                    what + ": " + source + " " + std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" +
                        std::to_string(dims.z) + " would need " + std::to_string(static_cast<uint64_t>(dense)) +
                        " bytes from a " + std::to_string(file_size) + "-byte file (at most " +
                        std::to_string(kMaxDenseExpansion) + " bytes per file byte + " +
                        std::to_string(kDenseAllowanceBytes >> 20) + " MiB); refused before allocating");
}

void check_selected_grid_claims(const VdbLayout& layout, const std::string& grid_name, uint64_t file_size,
                                const std::string& what) {
    const GridEntry* chosen = nullptr;
    int scalar = 0;
    for (const auto& g : layout.grids) {
        const bool is_scalar = dense_value_bytes(value_type_of_tree(g.tree_type)) > 0;
        if (!grid_name.empty() ? g.name == grid_name : is_scalar) {
            chosen = &g;
            ++scalar;
        }
    }
    if (scalar != 1 || !chosen) return;  // the reader reports which grid is missing or ambiguous
    const std::size_t bytes = dense_value_bytes(value_type_of_tree(chosen->tree_type));
    auto it = chosen->meta.find("dims_xyz");
    if (bytes == 0 || it == chosen->meta.end()) return;
    const std::string grid = what + " grid '" + chosen->name + "'";
    check_dense_bound(parse_dims_xyz(it->second.first, it->second.second, grid), bytes, file_size, grid,
                      "metadata dims_xyz");
}

}  // namespace tetlod::vdb_guard
