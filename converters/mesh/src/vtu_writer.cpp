// VTK XML UnstructuredGrid writer. Layout follows the VTK file-format document
// ("VTK File Formats", XML section): every array is stored in <AppendedData>
// as raw bytes after a '_' marker; a DataArray's offset counts from just after
// that marker. With header_type="UInt64" an uncompressed array is
// [UInt64 byte count][bytes]; a compressed one (vtkZLibDataCompressor) is
// [nblocks][block size][last block size][compressed size of each block] (all
// UInt64) followed by the zlib streams of each block, where "last block size" is
// the uncompressed size of a final partial block, 0 when every block is full.
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <sstream>
#include <vector>

#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/converters/vtk_writers.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"

namespace tetlod {

namespace {

struct Array {
    std::string xml_attributes;      // type, Name, NumberOfComponents
    std::vector<std::byte> encoded;  // header + payload, as it goes in the file
};

template <class T>
void append(std::vector<std::byte>& out, const T& v) {
    // resize + memcpy rather than insert(): GCC 12 warns falsely on the latter.
    const std::size_t at = out.size();
    out.resize(at + sizeof(T));
    std::memcpy(out.data() + at, &v, sizeof(T));
}

std::vector<std::byte> encode(const std::vector<std::byte>& raw, const VtuWriteOptions& opt,
                              const std::string& path) {
    std::vector<std::byte> out;
    if (!opt.compress) {
        append<uint64_t>(out, raw.size());
        out.resize(sizeof(uint64_t) + raw.size());
        if (!raw.empty()) std::memcpy(out.data() + sizeof(uint64_t), raw.data(), raw.size());
        return out;
    }
    const std::size_t bs = opt.block_size;
    const uint64_t nblocks = (raw.size() + bs - 1) / bs;
    const uint64_t last = raw.size() % bs;
    append<uint64_t>(out, nblocks);
    append<uint64_t>(out, bs);
    append<uint64_t>(out, last);
    const std::size_t sizes_at = out.size();
    out.resize(out.size() + nblocks * sizeof(uint64_t));
    std::vector<Bytef> block(compressBound(static_cast<uLong>(bs)));
    for (uint64_t b = 0; b < nblocks; ++b) {
        const std::size_t begin = b * bs;
        const std::size_t n = std::min(bs, raw.size() - begin);
        uLongf csize = static_cast<uLongf>(block.size());
        if (compress2(block.data(), &csize, reinterpret_cast<const Bytef*>(raw.data() + begin),
                      static_cast<uLong>(n), opt.compression_level) != Z_OK)
            throw Error(ErrorCode::IoError, "cannot write '" + path + "': zlib compression failed");
        const uint64_t c64 = csize;
        std::memcpy(out.data() + sizes_at + b * sizeof(uint64_t), &c64, sizeof c64);
        const std::size_t at = out.size();
        out.resize(at + csize);
        std::memcpy(out.data() + at, block.data(), csize);
    }
    return out;
}

template <class T>
std::vector<std::byte> bytes_of(const std::vector<T>& v) {
    std::vector<std::byte> out(v.size() * sizeof(T));
    if (!v.empty()) std::memcpy(out.data(), v.data(), out.size());
    return out;
}

std::string xml_escape(const std::string& s) {
    std::string r;
    for (char c : s) {
        switch (c) {
            case '&':
                r += "&amp;";
                break;
            case '<':
                r += "&lt;";
                break;
            case '>':
                r += "&gt;";
                break;
            case '"':
                r += "&quot;";
                break;
            case '\'':
                r += "&apos;";
                break;
            default:
                r += c;
        }
    }
    return r;
}

}  // namespace

void write_vtu(const TetMesh& mesh, const std::string& path, const VtuWriteOptions& options) {
    validate(mesh, "cannot write '" + path + "'");
    if (options.compress && (options.block_size == 0 || options.block_size > (1u << 30) ||
                             options.compression_level < 0 || options.compression_level > 9))
        throw Error(
            ErrorCode::InvalidArgument,
            "cannot write '" + path + "': block size must be in 1..2^30 and zlib level in 0..9");

    const std::size_t np = mesh.points.size();
    const std::size_t nt = mesh.tets.size();
    const std::string name = xml_escape(mesh.field_name);

    std::vector<double> coords;
    coords.reserve(3 * np);
    for (const auto& p : mesh.points) {
        const auto w = mesh.geometry.world(p);
        coords.insert(coords.end(), w.begin(), w.end());
    }
    std::vector<int64_t> connectivity;
    connectivity.reserve(4 * nt);
    for (const auto& t : mesh.tets) connectivity.insert(connectivity.end(), t.begin(), t.end());
    std::vector<int64_t> offsets(nt);
    for (std::size_t i = 0; i < nt; ++i) offsets[i] = static_cast<int64_t>(4 * (i + 1));
    const std::vector<uint8_t> types(nt, uint8_t{10});  // VTK_TETRA

    auto make = [&](std::string attrs, const std::vector<std::byte>& raw) {
        return Array{std::move(attrs), encode(raw, options, path)};
    };
    std::vector<Array> point_data, cell_data, points, cells;
    point_data.push_back(make("type=\"Float64\" Name=\"" + name + "\"", bytes_of(mesh.values)));
    if (!mesh.level.empty())
        cell_data.push_back(make("type=\"UInt8\" Name=\"level\"", bytes_of(mesh.level)));
    if (!mesh.error.empty())
        cell_data.push_back(make("type=\"Float32\" Name=\"error\"", bytes_of(mesh.error)));
    points.push_back(
        make("type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"", bytes_of(coords)));
    cells.push_back(make("type=\"Int64\" Name=\"connectivity\"", bytes_of(connectivity)));
    cells.push_back(make("type=\"Int64\" Name=\"offsets\"", bytes_of(offsets)));
    cells.push_back(make("type=\"UInt8\" Name=\"types\"", bytes_of(types)));

    std::ostringstream xml;
    uint64_t offset = 0;
    auto section = [&](const char* tag, const std::string& tag_attrs,
                       const std::vector<Array>& arrays) {
        xml << "      <" << tag << tag_attrs << ">\n";
        for (const auto& a : arrays) {
            xml << "        <DataArray " << a.xml_attributes << " format=\"appended\" offset=\""
                << offset << "\"/>\n";
            offset += a.encoded.size();
        }
        xml << "      </" << tag << ">\n";
    };
    const bool big = std::endian::native == std::endian::big;
    xml << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\""
        << (big ? "BigEndian" : "LittleEndian") << "\" header_type=\"UInt64\""
        << (options.compress ? " compressor=\"vtkZLibDataCompressor\"" : "") << ">\n"
        << "  <UnstructuredGrid>\n"
        << "    <Piece NumberOfPoints=\"" << np << "\" NumberOfCells=\"" << nt << "\">\n";
    section("PointData", " Scalars=\"" + name + "\"", point_data);
    section("CellData", cell_data.empty() ? "" : " Scalars=\"level\"", cell_data);
    section("Points", "", points);
    section("Cells", "", cells);
    xml << "    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";

    AtomicFile out(path);
    out.write(xml.str());
    for (const auto* group : {&point_data, &cell_data, &points, &cells})
        for (const auto& a : *group) out.write(a.encoded.data(), a.encoded.size());
    out.write(std::string_view("\n  </AppendedData>\n</VTKFile>\n"));
    out.commit();
}

MeshFormat vtu_mesh_format() {
    MeshFormat f;
    f.name = "vtu";
    f.extensions = {".vtu"};
    f.description = "(VTK XML)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions& o) {
        VtuWriteOptions vo;
        vo.compress = o.compress;
        write_vtu(m, path, vo);
    };
    return f;
}

}  // namespace tetlod
