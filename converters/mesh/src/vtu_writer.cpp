// VTK XML UnstructuredGrid writer. Layout follows the VTK file-format document
// ("VTK File Formats", XML section): every array is stored in <AppendedData>
// as raw bytes after a '_' marker; a DataArray's offset counts from just after
// that marker. With header_type="UInt64" an uncompressed array is
// [UInt64 byte count][bytes]; a compressed one is
// [nblocks][block size][last block size][compressed size of each block] (all
// UInt64) followed by the compressed blocks, where "last block size" is the
// uncompressed size of a final partial block, 0 when every block is full. Each
// block is compressed alone, as VTK's compressors do: zlib (a zlib stream),
// LZ4 (a raw LZ4 block) or LZMA (an .xz stream, CRC32 check).
#include <lz4.h>
#include <lzma.h>
#include <tbb/parallel_for.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <functional>
#include <cstring>
#include <limits>
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

int default_level(MeshCompression c) {
    switch (c) {
        case MeshCompression::Zlib: return 1;  // fast; level 6 costs ~3x the time for ~5% less
        case MeshCompression::Lz4: return 9;  // acceleration 1, LZ4's default
        case MeshCompression::Lzma: return 5;
        case MeshCompression::None: break;
    }
    return 0;
}

std::size_t block_bound(MeshCompression c, std::size_t n) {
    switch (c) {
        case MeshCompression::Zlib: return compressBound(static_cast<uLong>(n));
        case MeshCompression::Lz4: return std::size_t(LZ4_compressBound(int(n)));
        case MeshCompression::Lzma: return lzma_stream_buffer_bound(n);
        case MeshCompression::None: break;
    }
    return n;
}

// Compresses one block into `out` (block_bound bytes); returns its size, 0 on failure.
std::size_t compress_block(MeshCompression c, int level, const std::byte* in, std::size_t n, std::byte* out,
                           std::size_t cap) {
    switch (c) {
        case MeshCompression::Zlib: {
            uLongf size = static_cast<uLongf>(cap);
            return compress2(reinterpret_cast<Bytef*>(out), &size, reinterpret_cast<const Bytef*>(in),
                             static_cast<uLong>(n), level) == Z_OK
                       ? std::size_t(size)
                       : 0;
        }
        case MeshCompression::Lz4:  // VTK maps level L to acceleration 10 - L
            return std::size_t(std::max(0, LZ4_compress_fast(reinterpret_cast<const char*>(in), reinterpret_cast<char*>(out),
                                                             int(n), int(cap), 10 - level)));
        case MeshCompression::Lzma: {
            std::size_t pos = 0;
            return lzma_easy_buffer_encode(uint32_t(level), LZMA_CHECK_CRC32, nullptr,
                                           reinterpret_cast<const uint8_t*>(in), n, reinterpret_cast<uint8_t*>(out),
                                           &pos, cap) == LZMA_OK
                       ? pos
                       : 0;
        }
        case MeshCompression::None: break;
    }
    return 0;
}

std::vector<std::byte> encode(const std::vector<std::byte>& raw, const VtuWriteOptions& opt,
                              const std::string& path) {
    std::vector<std::byte> out;
    if (opt.compression == MeshCompression::None) {
        append<uint64_t>(out, raw.size());
        out.resize(sizeof(uint64_t) + raw.size());
        if (!raw.empty()) std::memcpy(out.data() + sizeof(uint64_t), raw.data(), raw.size());
        return out;
    }
    const int level = opt.compression_level ? opt.compression_level : default_level(opt.compression);
    const std::size_t bs = opt.block_size;
    const uint64_t nblocks = (raw.size() + bs - 1) / bs;
    const uint64_t last = raw.size() % bs;
    // Blocks are independent: compress them in parallel into slots of the
    // bound's size, then pack them in order (the same bytes for any thread count).
    const std::size_t cap = block_bound(opt.compression, bs);
    std::vector<std::byte> slots(std::size_t(nblocks) * cap);
    std::vector<uint64_t> sizes(std::size_t(nblocks), 0);
    tbb::parallel_for(uint64_t{0}, nblocks, [&](uint64_t b) {
        const std::size_t begin = std::size_t(b) * bs;
        const std::size_t n = std::min(bs, raw.size() - begin);
        sizes[b] = compress_block(opt.compression, level, raw.data() + begin, n, slots.data() + b * cap, cap);
    });
    for (uint64_t size : sizes)
        if (size == 0)
            throw Error(ErrorCode::IoError, "cannot write '" + path + "': " + mesh_compression_name(opt.compression) +
                                                " compression failed");
    append<uint64_t>(out, nblocks);
    append<uint64_t>(out, bs);
    append<uint64_t>(out, last);
    for (uint64_t size : sizes) append<uint64_t>(out, size);
    for (uint64_t b = 0; b < nblocks; ++b) {
        const std::size_t at = out.size();
        out.resize(at + sizes[b]);
        std::memcpy(out.data() + at, slots.data() + b * cap, sizes[b]);
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


std::string compressor_attribute(MeshCompression c) {
    switch (c) {
        case MeshCompression::Zlib: return " compressor=\"vtkZLibDataCompressor\"";
        case MeshCompression::Lz4: return " compressor=\"vtkLZ4DataCompressor\"";
        case MeshCompression::Lzma: return " compressor=\"vtkLZMADataCompressor\"";
        case MeshCompression::None: break;
    }
    return "";
}

// The values in the mesh's own sample type (exact: they came from it).
template <class T>
std::vector<std::byte> values_as(const std::vector<double>& values) {
    std::vector<std::byte> out(values.size() * sizeof(T));
    for (std::size_t i = 0; i < values.size(); ++i) {
        const T v = static_cast<T>(values[i]);
        std::memcpy(out.data() + i * sizeof(T), &v, sizeof(T));
    }
    return out;
}

const char* vtk_type_name(ValueType t) {
    switch (t) {
        case ValueType::U8: return "UInt8";
        case ValueType::I8: return "Int8";
        case ValueType::U16: return "UInt16";
        case ValueType::I16: return "Int16";
        case ValueType::U32: return "UInt32";
        case ValueType::I32: return "Int32";
        case ValueType::F32: return "Float32";
        case ValueType::F64: return "Float64";
    }
    return "Float64";
}

// Connectivity and offsets: Int32 when every id fits (half the bytes), else Int64.
template <class I>
void add_cells(std::vector<Array>& cells, const TetMesh& mesh, const char* type,
               const std::function<Array(std::string, const std::vector<std::byte>&)>& make) {
    const std::size_t nt = mesh.tets.size();
    std::vector<I> connectivity(4 * nt), offsets(nt);
    for (std::size_t i = 0; i < nt; ++i) {
        for (int k = 0; k < 4; ++k) connectivity[4 * i + k] = static_cast<I>(mesh.tets[i][k]);
        offsets[i] = static_cast<I>(4 * (i + 1));
    }
    cells.push_back(make(std::string("type=\"") + type + "\" Name=\"connectivity\"", bytes_of(connectivity)));
    cells.push_back(make(std::string("type=\"") + type + "\" Name=\"offsets\"", bytes_of(offsets)));
}

}  // namespace

const char* mesh_compression_name(MeshCompression c) {
    switch (c) {
        case MeshCompression::None: return "none";
        case MeshCompression::Zlib: return "zlib";
        case MeshCompression::Lz4: return "lz4";
        case MeshCompression::Lzma: return "lzma";
    }
    return "none";
}

std::optional<MeshCompression> parse_mesh_compression(std::string_view name) {
    for (MeshCompression c : {MeshCompression::None, MeshCompression::Zlib, MeshCompression::Lz4, MeshCompression::Lzma})
        if (name == mesh_compression_name(c)) return c;
    return std::nullopt;
}

void write_vtu(const TetMesh& mesh, const std::string& path, const VtuWriteOptions& options) {
    validate(mesh, "cannot write '" + path + "'");
    if (options.compression != MeshCompression::None &&
        (options.block_size == 0 || options.block_size > (1u << 30) || options.compression_level < 0 ||
         options.compression_level > 9))
        throw Error(ErrorCode::InvalidArgument,
                    "cannot write '" + path + "': block size must be in 1..2^30 and the level in 0..9");

    const std::size_t np = mesh.points.size();
    const std::size_t nt = mesh.tets.size();
    const std::string name = xml_escape(mesh.field_name);

    std::vector<double> coords;
    coords.reserve(3 * np);
    for (const auto& p : mesh.points) {
        const auto w = mesh.geometry.world(p);
        coords.insert(coords.end(), w.begin(), w.end());
    }
    auto make = [&](std::string attrs, const std::vector<std::byte>& raw) {
        return Array{std::move(attrs), encode(raw, options, path)};
    };
    std::vector<Array> point_data, cell_data, points, cells;
    const std::vector<std::byte> values = dispatch_value_type(mesh.value_type, [&](auto tag) {
        return values_as<decltype(tag)>(mesh.values);
    });
    point_data.push_back(make(std::string("type=\"") + vtk_type_name(mesh.value_type) + "\" Name=\"" + name + "\"", values));
    if (!mesh.level.empty())
        cell_data.push_back(make("type=\"UInt8\" Name=\"level\"", bytes_of(mesh.level)));
    if (!mesh.error.empty())
        cell_data.push_back(make("type=\"Float32\" Name=\"error\"", bytes_of(mesh.error)));
    points.push_back(
        make("type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"", bytes_of(coords)));
    if (4 * nt <= std::size_t(std::numeric_limits<int32_t>::max()))
        add_cells<int32_t>(cells, mesh, "Int32", make);
    else
        add_cells<int64_t>(cells, mesh, "Int64", make);
    const std::vector<uint8_t> types(nt, uint8_t{10});  // VTK_TETRA
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
        << compressor_attribute(options.compression) << ">\n"
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
        vo.compression = o.compression;
        vo.compression_level = o.compression_level;
        write_vtu(m, path, vo);
    };
    return f;
}

}  // namespace tetlod
