// VTK writers: each file is decoded again here by a small independent reader
// (XML attributes + appended binary, zlib, LZ4 and LZMA blocks included; legacy big-endian
// sections) and compared with the mesh, and, when python3-vtk9 is installed,
// read by VTK itself.
#include <gtest/gtest.h>
#include <lz4.h>
#include <lzma.h>
#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/converters/vtk_writers.hpp"
#include "tetlod/core/error.hpp"

namespace fs = std::filesystem;
using namespace tetlod;

namespace {

std::string tmp(const std::string& name) { return (fs::path(TETLOD_TEST_TMP) / name).string(); }

std::string slurp(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// A Kuhn split of an nx*ny*nz block of unit cubes, positively oriented, with
// distinct values, levels and errors per element so any mix-up shows.
TetMesh grid_mesh(int n) {
    TetMesh m;
    m.geometry.spacing = {0.5, 2.0, 1.5};
    m.geometry.origin = {-1.0, 10.0, 0.25};
    m.field_name = "density";
    const int np = n + 1;
    for (int k = 0; k < np; ++k)
        for (int j = 0; j < np; ++j)
            for (int i = 0; i < np; ++i) {
                m.points.push_back({i, j, k});
                m.values.push_back(i * 1.5 - j * 0.25 + k * k);
            }
    auto id = [&](int i, int j, int k) { return static_cast<uint32_t>((k * np + j) * np + i); };
    const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                for (int p = 0; p < 6; ++p) {
                    int c[3] = {i, j, k};
                    std::array<uint32_t, 4> t{id(i, j, k), 0, 0, 0};
                    for (int s = 0; s < 3; ++s) {
                        ++c[perm[p][s]];
                        t[s + 1] = id(c[0], c[1], c[2]);
                    }
                    if (p >= 3) std::swap(t[2], t[3]);  // odd permutations: fix orientation
                    m.tets.push_back(t);
                    m.level.push_back(static_cast<uint8_t>((m.tets.size() * 7) % 19));
                    m.error.push_back(static_cast<float>(m.tets.size()) * 0.125f);
                }
    return m;
}

// ---- a minimal VTU reader -------------------------------------------------

struct VtuArray {
    std::string type, name;
    int components = 1;
    std::vector<std::byte> bytes;
    template <class T>
    std::vector<T> as() const {
        std::vector<T> v(bytes.size() / sizeof(T));
        std::memcpy(v.data(), bytes.data(), v.size() * sizeof(T));
        return v;
    }
};

struct Vtu {
    std::map<std::string, std::string> file_attrs;
    uint64_t points = 0, cells = 0;
    std::map<std::string, VtuArray> arrays;  // by Name
};

std::map<std::string, std::string> attributes(const std::string& tag) {
    std::map<std::string, std::string> a;
    static const std::regex attr(R"re((\w+)="([^"]*)")re");
    for (std::sregex_iterator it(tag.begin(), tag.end(), attr), end; it != end; ++it)
        a[(*it)[1]] = (*it)[2];
    return a;
}

uint64_t u64_at(const std::string& s, std::size_t pos) {
    if (pos + 8 > s.size()) throw std::runtime_error("vtu: header past end of file");
    uint64_t v;
    std::memcpy(&v, s.data() + pos, 8);
    return v;
}

Vtu read_vtu(const std::string& path) {
    const std::string s = slurp(path);
    Vtu vtu;
    const auto file_tag_end = s.find('>', s.find("<VTKFile"));
    vtu.file_attrs = attributes(s.substr(0, file_tag_end));
    const auto piece = attributes(s.substr(s.find("<Piece"), 100));
    vtu.points = std::stoull(piece.at("NumberOfPoints"));
    vtu.cells = std::stoull(piece.at("NumberOfCells"));
    const bool compressed = vtu.file_attrs.count("compressor") > 0;
    const std::string compressor = compressed ? vtu.file_attrs.at("compressor") : "";
    // One block back to `usize` bytes with the library of the named compressor.
    auto inflate_block = [&](const char* in, std::size_t csize, std::byte* out, std::size_t usize) -> std::size_t {
        if (compressor == "vtkZLibDataCompressor") {
            uLongf n = static_cast<uLongf>(usize);
            return uncompress(reinterpret_cast<Bytef*>(out), &n, reinterpret_cast<const Bytef*>(in), csize) == Z_OK
                       ? n
                       : 0;
        }
        if (compressor == "vtkLZ4DataCompressor")
            return std::size_t(std::max(0, LZ4_decompress_safe(in, reinterpret_cast<char*>(out), int(csize), int(usize))));
        if (compressor == "vtkLZMADataCompressor") {
            uint64_t limit = UINT64_MAX;
            std::size_t in_pos = 0, out_pos = 0;
            return lzma_stream_buffer_decode(&limit, 0, nullptr, reinterpret_cast<const uint8_t*>(in), &in_pos, csize,
                                             reinterpret_cast<uint8_t*>(out), &out_pos, usize) == LZMA_OK
                       ? out_pos
                       : 0;
        }
        ADD_FAILURE() << "unknown compressor " << compressor;
        return 0;
    };
    const auto appended = s.find("<AppendedData");
    const auto base = s.find('_', appended) + 1;

    static const std::regex data_array(R"(<DataArray[^>]*>)");
    const std::string head = s.substr(0, appended);
    for (std::sregex_iterator it(head.begin(), head.end(), data_array), end; it != end; ++it) {
        auto a = attributes(it->str());
        VtuArray arr;
        arr.type = a.at("type");
        arr.name = a.at("Name");
        if (a.count("NumberOfComponents")) arr.components = std::stoi(a["NumberOfComponents"]);
        EXPECT_EQ(a.at("format"), "appended");
        std::size_t pos = base + std::stoull(a.at("offset"));
        if (!compressed) {
            const uint64_t n = u64_at(s, pos);
            arr.bytes.resize(n);
            std::memcpy(arr.bytes.data(), s.data() + pos + 8, n);
        } else {
            const uint64_t nblocks = u64_at(s, pos), bs = u64_at(s, pos + 8),
                           last = u64_at(s, pos + 16);
            std::size_t data = pos + 24 + 8 * nblocks;
            for (uint64_t b = 0; b < nblocks; ++b) {
                const uint64_t csize = u64_at(s, pos + 24 + 8 * b);
                const std::size_t usize = (b + 1 == nblocks && last != 0) ? last : bs;
                const std::size_t at = arr.bytes.size();
                arr.bytes.resize(at + usize);
                EXPECT_EQ(inflate_block(s.data() + data, csize, arr.bytes.data() + at, usize), usize);
                data += csize;
            }
        }
        vtu.arrays[arr.name] = std::move(arr);
    }
    return vtu;
}

void expect_vtu_matches(const Vtu& v, const TetMesh& m) {
    ASSERT_EQ(v.points, m.points.size());
    ASSERT_EQ(v.cells, m.tets.size());
    EXPECT_EQ(v.file_attrs.at("header_type"), "UInt64");
    EXPECT_EQ(v.file_attrs.at("type"), "UnstructuredGrid");

    const auto& pts = v.arrays.at("Points");
    EXPECT_EQ(pts.type, "Float64");
    EXPECT_EQ(pts.components, 3);
    const auto xyz = pts.as<double>();
    ASSERT_EQ(xyz.size(), 3 * m.points.size());
    for (std::size_t i = 0; i < m.points.size(); ++i)
        for (int a = 0; a < 3; ++a)
            ASSERT_EQ(xyz[3 * i + a],
                      m.geometry.origin[a] + m.geometry.spacing[a] * m.points[i][a]);

    // The values in the mesh's own sample type.
    const auto& field = v.arrays.at(m.field_name);
    std::vector<double> values;
    if (m.value_type == ValueType::F64) {
        EXPECT_EQ(field.type, "Float64");
        values = field.as<double>();
    } else if (m.value_type == ValueType::U8) {
        EXPECT_EQ(field.type, "UInt8");
        for (uint8_t x : field.as<uint8_t>()) values.push_back(x);
    } else if (m.value_type == ValueType::I16) {
        EXPECT_EQ(field.type, "Int16");
        for (int16_t x : field.as<int16_t>()) values.push_back(x);
    } else if (m.value_type == ValueType::F32) {
        EXPECT_EQ(field.type, "Float32");
        for (float x : field.as<float>()) values.push_back(x);
    } else {
        ADD_FAILURE() << "test reader: add this value type";
    }
    EXPECT_EQ(values, m.values);
    EXPECT_EQ(v.arrays.at("level").type, "UInt8");
    EXPECT_EQ(v.arrays.at("level").as<uint8_t>(), m.level);
    EXPECT_EQ(v.arrays.at("error").type, "Float32");
    EXPECT_EQ(v.arrays.at("error").as<float>(), m.error);

    // Int32 ids while they fit (every mesh here).
    EXPECT_EQ(v.arrays.at("connectivity").type, "Int32");
    EXPECT_EQ(v.arrays.at("offsets").type, "Int32");
    std::vector<int64_t> conn, offsets;
    for (int32_t x : v.arrays.at("connectivity").as<int32_t>()) conn.push_back(x);
    for (int32_t x : v.arrays.at("offsets").as<int32_t>()) offsets.push_back(x);
    const auto types = v.arrays.at("types").as<uint8_t>();
    ASSERT_EQ(conn.size(), 4 * m.tets.size());
    ASSERT_EQ(offsets.size(), m.tets.size());
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
        for (int c = 0; c < 4; ++c) ASSERT_EQ(conn[4 * t + c], m.tets[t][c]);
        ASSERT_EQ(offsets[t], static_cast<int64_t>(4 * (t + 1)));
        ASSERT_EQ(types[t], 10);
    }
}

// ---- legacy reader ------------------------------------------------------------

class LegacyReader {
  public:
    explicit LegacyReader(const std::string& path) : s_(slurp(path)) {}
    std::string line() {
        const auto e = s_.find('\n', pos_);
        std::string l = s_.substr(pos_, e - pos_);
        pos_ = e + 1;
        return l;
    }
    template <class T>
    std::vector<T> big_endian(std::size_t n) {
        std::vector<T> v(n);
        for (auto& x : v) {
            std::byte b[sizeof(T)];
            std::memcpy(b, s_.data() + pos_, sizeof(T));
            if constexpr (std::endian::native == std::endian::little)
                std::reverse(b, b + sizeof(T));
            std::memcpy(&x, b, sizeof(T));
            pos_ += sizeof(T);
        }
        EXPECT_EQ(s_.at(pos_), '\n');
        ++pos_;
        return v;
    }
    bool at_end() const { return pos_ == s_.size(); }

  private:
    std::string s_;
    std::size_t pos_ = 0;
};

template <class F>
ErrorCode error_of(F&& f, std::string* message = nullptr) {
    try {
        f();
    } catch (const Error& e) {
        if (message) *message = e.what();
        return e.code();
    }
    return ErrorCode::Ok;
}

}  // namespace

// The mesh with integer values of `type` (as a volume of that type gives).
TetMesh typed_mesh(int n, ValueType type) {
    TetMesh m = grid_mesh(n);
    m.value_type = type;
    for (std::size_t i = 0; i < m.values.size(); ++i)
        m.values[i] = type == ValueType::U8 ? double(i % 251) : double(int(i % 4001) - 2000);
    return m;
}

TEST(VtuWriter, CompressedRoundTrip) {
    const TetMesh m = grid_mesh(4);
    write_vtu(m, tmp("c.vtu"));
    const Vtu v = read_vtu(tmp("c.vtu"));
    EXPECT_EQ(v.file_attrs.at("compressor"), "vtkZLibDataCompressor");  // the default
    expect_vtu_matches(v, m);
    const std::pair<MeshCompression, const char*> compressors[] = {
        {MeshCompression::Zlib, "vtkZLibDataCompressor"},
        {MeshCompression::Lz4, "vtkLZ4DataCompressor"},
        {MeshCompression::Lzma, "vtkLZMADataCompressor"}};
    for (const auto& [c, attr] : compressors)
        for (int level : {0, 1, 9}) {
            SCOPED_TRACE(std::string(attr) + " level " + std::to_string(level));
            VtuWriteOptions o;
            o.compression = c;
            o.compression_level = level;
            o.block_size = 1000;  // many blocks, compressed in parallel
            write_vtu(m, tmp("c.vtu"), o);
            const Vtu vc = read_vtu(tmp("c.vtu"));
            EXPECT_EQ(vc.file_attrs.at("compressor"), attr);
            expect_vtu_matches(vc, m);
        }
}

TEST(VtuWriter, ValuesKeepTheirType) {
    for (ValueType t : {ValueType::U8, ValueType::I16}) {
        SCOPED_TRACE(value_type_name(t));
        const TetMesh m = typed_mesh(3, t);
        write_vtu(m, tmp("typed.vtu"));
        expect_vtu_matches(read_vtu(tmp("typed.vtu")), m);
    }
}

TEST(VtuWriter, NamesOfTheCompressors) {
    for (MeshCompression c : {MeshCompression::None, MeshCompression::Zlib, MeshCompression::Lz4, MeshCompression::Lzma})
        EXPECT_EQ(parse_mesh_compression(mesh_compression_name(c)), c);
    EXPECT_FALSE(parse_mesh_compression("gzip").has_value());
    VtuWriteOptions o;
    o.compression_level = 10;
    EXPECT_EQ(error_of([&] { write_vtu(grid_mesh(1), tmp("lvl.vtu"), o); }), ErrorCode::InvalidArgument);
}

TEST(VtuWriter, UncompressedRoundTrip) {
    const TetMesh m = grid_mesh(3);
    VtuWriteOptions o;
    o.compression = MeshCompression::None;
    write_vtu(m, tmp("u.vtu"), o);
    const Vtu v = read_vtu(tmp("u.vtu"));
    EXPECT_EQ(v.file_attrs.count("compressor"), 0u);
    expect_vtu_matches(v, m);
}

TEST(VtuWriter, BlockBoundaries) {
    // Small blocks force many blocks, a partial last one, and (block size 8 with
    // 8-byte Float64 values) arrays that end exactly on a block boundary.
    const TetMesh m = grid_mesh(2);
    for (std::size_t bs : {std::size_t{8}, std::size_t{100}, std::size_t{1} << 20}) {
        SCOPED_TRACE(bs);
        VtuWriteOptions o;
        o.block_size = bs;
        write_vtu(m, tmp("b.vtu"), o);
        expect_vtu_matches(read_vtu(tmp("b.vtu")), m);
    }
}

TEST(VtuWriter, EmptyMesh) {
    TetMesh m;
    write_vtu(m, tmp("empty.vtu"));
    const Vtu v = read_vtu(tmp("empty.vtu"));
    EXPECT_EQ(v.points, 0u);
    EXPECT_EQ(v.cells, 0u);
}

TEST(VtuWriter, EscapesFieldName) {
    TetMesh m = grid_mesh(1);
    m.field_name = "a<b&\"c\"";
    write_vtu(m, tmp("esc.vtu"));
    const std::string s = slurp(tmp("esc.vtu"));
    EXPECT_NE(s.find("Name=\"a&lt;b&amp;&quot;c&quot;\""), std::string::npos);
}

TEST(VtkLegacyWriter, RoundTrip) {
    const TetMesh m = grid_mesh(3);
    write_vtk_legacy(m, tmp("m.vtk"));
    LegacyReader r(tmp("m.vtk"));
    EXPECT_EQ(r.line(), "# vtk DataFile Version 3.0");
    r.line();
    EXPECT_EQ(r.line(), "BINARY");
    EXPECT_EQ(r.line(), "DATASET UNSTRUCTURED_GRID");
    EXPECT_EQ(r.line(), "POINTS " + std::to_string(m.points.size()) + " double");
    const auto xyz = r.big_endian<double>(3 * m.points.size());
    for (std::size_t i = 0; i < m.points.size(); ++i)
        for (int a = 0; a < 3; ++a)
            ASSERT_EQ(xyz[3 * i + a],
                      m.geometry.origin[a] + m.geometry.spacing[a] * m.points[i][a]);
    const auto nt = m.tets.size();
    EXPECT_EQ(r.line(), "CELLS " + std::to_string(nt) + " " + std::to_string(5 * nt));
    const auto cells = r.big_endian<int32_t>(5 * nt);
    for (std::size_t t = 0; t < nt; ++t) {
        ASSERT_EQ(cells[5 * t], 4);
        for (int c = 0; c < 4; ++c)
            ASSERT_EQ(cells[5 * t + 1 + c], static_cast<int32_t>(m.tets[t][c]));
    }
    EXPECT_EQ(r.line(), "CELL_TYPES " + std::to_string(nt));
    for (int32_t type : r.big_endian<int32_t>(nt)) ASSERT_EQ(type, 10);
    EXPECT_EQ(r.line(), "POINT_DATA " + std::to_string(m.points.size()));
    EXPECT_EQ(r.line(), "SCALARS density double 1");
    EXPECT_EQ(r.line(), "LOOKUP_TABLE default");
    EXPECT_EQ(r.big_endian<double>(m.points.size()), m.values);
    EXPECT_EQ(r.line(), "CELL_DATA " + std::to_string(nt));
    EXPECT_EQ(r.line(), "FIELD FieldData 2");
    EXPECT_EQ(r.line(), "level 1 " + std::to_string(nt) + " unsigned_char");
    EXPECT_EQ(r.big_endian<uint8_t>(nt), m.level);
    EXPECT_EQ(r.line(), "error 1 " + std::to_string(nt) + " float");
    EXPECT_EQ(r.big_endian<float>(nt), m.error);
    EXPECT_TRUE(r.at_end());
}

TEST(VtkLegacyWriter, ValuesKeepTheirType) {
    const TetMesh m = typed_mesh(2, ValueType::I16);
    write_vtk_legacy(m, tmp("typed.vtk"));
    const std::string s = slurp(tmp("typed.vtk"));
    const std::string head = "SCALARS density short 1\nLOOKUP_TABLE default\n";
    const auto at = s.find(head);
    ASSERT_NE(at, std::string::npos);
    std::vector<double> got;
    for (std::size_t i = 0; i < m.values.size(); ++i) {
        const auto* b = reinterpret_cast<const unsigned char*>(s.data() + at + head.size() + 2 * i);
        got.push_back(double(int16_t(uint16_t(b[0] << 8 | b[1]))));  // big-endian
    }
    EXPECT_EQ(got, m.values);
}

TEST(MeshWriters, RefuseInconsistentMeshesWithoutWriting) {
    TetMesh m = grid_mesh(1);
    m.tets.push_back({0, 1, 2, 99});
    m.level.push_back(0);
    m.error.push_back(0);
    std::string msg;
    EXPECT_EQ(error_of([&] { write_vtu(m, tmp("bad.vtu")); }, &msg), ErrorCode::InvalidArgument);
    EXPECT_NE(msg.find("bad.vtu"), std::string::npos) << msg;
    EXPECT_NE(msg.find("99"), std::string::npos) << msg;
    EXPECT_FALSE(fs::exists(tmp("bad.vtu")));
    m = grid_mesh(1);
    m.values.pop_back();
    EXPECT_EQ(error_of([&] { write_vtk_legacy(m, tmp("bad.vtk")); }), ErrorCode::InvalidArgument);
    EXPECT_FALSE(fs::exists(tmp("bad.vtk")));
}

TEST(MeshWriters, DispatchByExtensionAndFormat) {
    const TetMesh m = grid_mesh(1);
    write_tet_mesh(m, tmp("d.vtu"));
    EXPECT_EQ(slurp(tmp("d.vtu")).rfind("<?xml", 0), 0u);
    write_tet_mesh(m, tmp("D.VTK"));
    EXPECT_EQ(slurp(tmp("D.VTK")).rfind("# vtk DataFile", 0), 0u);
    write_tet_mesh(m, tmp("legacy.out"), "vtk");
    EXPECT_EQ(slurp(tmp("legacy.out")).rfind("# vtk DataFile", 0), 0u);
    MeshWriteOptions plain;
    plain.compression = MeshCompression::None;
    write_tet_mesh(m, tmp("plain.vtu"), "", plain);
    EXPECT_EQ(read_vtu(tmp("plain.vtu")).file_attrs.count("compressor"), 0u);

    std::string msg;
    EXPECT_EQ(error_of([&] { write_tet_mesh(m, tmp("m.obj")); }, &msg), ErrorCode::InvalidArgument);
    EXPECT_NE(msg.find("m.obj"), std::string::npos) << msg;
    EXPECT_NE(msg.find("vtu"), std::string::npos) << msg;
    EXPECT_NE(msg.find("vtk"), std::string::npos) << msg;
    EXPECT_EQ(error_of([&] { write_tet_mesh(m, tmp("noext")); }), ErrorCode::InvalidArgument);
}

TEST(MeshWriters, ReadBackByVtk) {
    if (std::system("/usr/bin/python3 -c 'import vtk' >/dev/null 2>&1") != 0)
        GTEST_SKIP() << "python3-vtk9 is not installed (/usr/bin/python3 -c 'import vtk' failed)";
  for (ValueType type : {ValueType::F64, ValueType::U8}) {
    SCOPED_TRACE(value_type_name(type));
    const TetMesh m = type == ValueType::F64 ? grid_mesh(3) : typed_mesh(3, type);
    // Every compressor VTK knows, and the legacy format.
    std::vector<std::string> files;
    for (MeshCompression c : {MeshCompression::None, MeshCompression::Zlib, MeshCompression::Lz4, MeshCompression::Lzma}) {
        VtuWriteOptions o;
        o.compression = c;
        o.block_size = 4096;
        files.push_back(tmp(std::string("vtk_") + mesh_compression_name(c) + ".vtu"));
        write_vtu(m, files.back(), o);
    }
    files.push_back(tmp("vtk.vtk"));
    write_vtk_legacy(m, files.back());
    const std::string out = tmp("vtk.txt");
    std::string cmd = std::string("/usr/bin/python3 ") + TETLOD_READ_VTK_PY;
    for (const auto& f : files) cmd += " " + f;
    cmd += " > " + out;
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

    double value_sum = 0;
    for (double v : m.values) value_sum += v;
    uint64_t level_sum = 0;
    for (uint8_t l : m.level) level_sum += l;
    float error_max = 0;
    for (float e : m.error) error_max = std::max(error_max, e);

    std::istringstream lines(slurp(out));
    for (std::size_t f = 0; f < files.size(); ++f) {
        std::string path;
        uint64_t points = 0, cells = 0, tetras = 0, positive = 0, levels = 0;
        double values = 0, errors = 0, xmin = 0, ymax = 0;
        lines >> path >> points >> cells >> tetras >> positive >> values >> levels >> errors >>
            xmin >> ymax;
        SCOPED_TRACE(path);
        EXPECT_EQ(points, m.points.size());
        EXPECT_EQ(cells, m.tets.size());
        EXPECT_EQ(tetras, m.tets.size());
        EXPECT_EQ(positive, m.tets.size());  // every tet positively oriented in world space
        EXPECT_NEAR(values, value_sum, 1e-9 * std::abs(value_sum));
        EXPECT_EQ(levels, level_sum);
        EXPECT_FLOAT_EQ(errors, error_max);
        EXPECT_DOUBLE_EQ(xmin, -1.0);
        EXPECT_DOUBLE_EQ(ymax, 10.0 + 2.0 * 3);
    }
  }
}
