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
#include <memory>
#include <span>
#include <sstream>
#include <vector>

#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/converters/vtk_writers.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/spill_file.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"

namespace tetlod {

namespace {

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

/// One DataArray of the appended section, encoded as its bytes arrive: raw
/// bytes gather into a batch of blocks, each batch is compressed in parallel
/// (blocks independently, so the bytes do not depend on the thread count) and
/// spilled to a temporary file; memory holds one batch and the block sizes.
class StreamArray {
public:
    StreamArray(std::string attrs, const std::string& path, const VtuWriteOptions& opt)
        : attrs_(std::move(attrs)), path_(path), opt_(opt), spill_(path),
          level_(opt.compression_level ? opt.compression_level : default_level(opt.compression)) {}

    const std::string& attributes() const { return attrs_; }

    void push(const void* data, std::size_t n) {
        const auto* p = static_cast<const std::byte*>(data);
        raw_bytes_ += n;
        if (opt_.compression == MeshCompression::None) {
            spill_.write(p, n);
            return;
        }
        while (n > 0) {
            const std::size_t take = std::min(n, batch_bytes() - pending_.size());
            pending_.insert(pending_.end(), p, p + take);
            p += take;
            n -= take;
            if (pending_.size() == batch_bytes()) compress_pending();
        }
    }
    template <class T> void push_values(std::span<const T> v) { push(v.data(), v.size_bytes()); }

    /// Compresses what remains; call once, before encoded_size / write_to.
    void close() {
        if (opt_.compression != MeshCompression::None && !pending_.empty()) compress_pending();
    }
    /// Bytes of the array in the file (header included).
    uint64_t encoded_size() const {
        if (opt_.compression == MeshCompression::None) return 8 + raw_bytes_;
        return 8 * (3 + sizes_.size()) + spill_.size();
    }
    void write_to(AtomicFile& out) {
        std::vector<std::byte> header;
        if (opt_.compression == MeshCompression::None) {
            append<uint64_t>(header, raw_bytes_);
        } else {
            append<uint64_t>(header, sizes_.size());
            append<uint64_t>(header, opt_.block_size);
            append<uint64_t>(header, raw_bytes_ % opt_.block_size);
            for (uint64_t size : sizes_) append<uint64_t>(header, size);
        }
        out.write(header.data(), header.size());
        spill_.copy_to(out);
    }

private:
    std::size_t batch_bytes() const { return opt_.block_size * kBlocksPerBatch; }

    void compress_pending() {
        const std::size_t bs = opt_.block_size;
        const std::size_t nblocks = (pending_.size() + bs - 1) / bs;
        const std::size_t cap = block_bound(opt_.compression, bs);
        slots_.resize(nblocks * cap);
        std::vector<uint64_t> sizes(nblocks, 0);
        tbb::parallel_for(std::size_t{0}, nblocks, [&](std::size_t b) {
            const std::size_t begin = b * bs;
            const std::size_t n = std::min(bs, pending_.size() - begin);
            sizes[b] = compress_block(opt_.compression, level_, pending_.data() + begin, n, slots_.data() + b * cap, cap);
        });
        for (std::size_t b = 0; b < nblocks; ++b) {
            if (sizes[b] == 0)
                throw Error(ErrorCode::IoError, "cannot write '" + path_ + "': " +
                                                    mesh_compression_name(opt_.compression) + " compression failed");
            spill_.write(slots_.data() + b * cap, sizes[b]);
            sizes_.push_back(sizes[b]);
        }
        pending_.clear();
    }

    static constexpr std::size_t kBlocksPerBatch = 64;
    std::string attrs_;
    std::string path_;
    VtuWriteOptions opt_;
    SpillFile spill_;
    int level_;
    std::vector<std::byte> pending_, slots_;
    std::vector<uint64_t> sizes_;
    uint64_t raw_bytes_ = 0;
};

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

/// The streaming .vtu writer. Arrays go to the appended section in this order:
/// point data, cell data, points, cells (the XML lists each with its offset,
/// known once every array is encoded, so the file is assembled in finish()).
class VtuSink final : public TetMeshSink {
public:
    VtuSink(const std::string& path, const VtuWriteOptions& options) : path_(path), opt_(options), out_(path) {
        if (options.compression != MeshCompression::None &&
            (options.block_size == 0 || options.block_size > (1u << 30) || options.compression_level < 0 ||
             options.compression_level > 9))
            throw Error(ErrorCode::InvalidArgument,
                        "cannot write '" + path + "': block size must be in 1..2^30 and the level in 0..9");
    }

    void begin(const TetMesh& v, uint64_t tet_count) override {
        validate_vertices(v, "cannot write '" + path_ + "'");
        np_ = v.points.size();
        nt_ = tet_count;
        name_ = xml_escape(v.field_name);
        checks_.begin("cannot write '" + path_ + "'", np_, nt_);
        wide_ = 4 * nt_ > uint64_t(std::numeric_limits<int32_t>::max());
        const char* id_type = wide_ ? "Int64" : "Int32";
        auto array = [&](std::string attrs) { return std::make_unique<StreamArray>(std::move(attrs), path_, opt_); };
        values_ = array(std::string("type=\"") + vtk_type_name(v.value_type) + "\" Name=\"" + name_ + "\"");
        level_ = array("type=\"UInt8\" Name=\"level\"");
        error_ = array("type=\"Float32\" Name=\"error\"");
        points_ = array("type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"");
        connectivity_ = array(std::string("type=\"") + id_type + "\" Name=\"connectivity\"");
        offsets_ = array(std::string("type=\"") + id_type + "\" Name=\"offsets\"");
        types_ = array("type=\"UInt8\" Name=\"types\"");
        // Vertices in pieces: the field in its own sample type (exact: it came from it), world coordinates.
        constexpr std::size_t kPiece = 1 << 16;
        dispatch_value_type(v.value_type, [&](auto tag) {
            using T = decltype(tag);
            std::vector<T> buf;
            for (std::size_t i = 0; i < np_; i += kPiece) {
                buf.clear();
                for (std::size_t j = i; j < std::min(np_, i + kPiece); ++j) buf.push_back(static_cast<T>(v.values[j]));
                values_->push_values(std::span<const T>(buf));
            }
        });
        std::vector<double> coords;
        for (std::size_t i = 0; i < np_; i += kPiece) {
            coords.clear();
            for (std::size_t j = i; j < std::min(np_, i + kPiece); ++j) {
                const auto w = v.geometry.world(v.points[j]);
                coords.insert(coords.end(), w.begin(), w.end());
            }
            points_->push_values(std::span<const double>(coords));
        }
    }

    void add(std::span<const std::array<uint32_t, 4>> tets, std::span<const uint8_t> level,
             std::span<const float> error) override {
        const uint64_t first = checks_.added();
        checks_.batch(tets, level.size(), error.size());
        if (wide_) push_cells<int64_t>(tets, first); else push_cells<int32_t>(tets, first);
        level_->push_values(level);
        error_->push_values(error);
        const std::vector<uint8_t> types(tets.size(), uint8_t{10});  // VTK_TETRA
        types_->push_values(std::span<const uint8_t>(types));
    }

    void finish() override {
        checks_.finish();
        for (StreamArray* a : all()) a->close();
        std::ostringstream xml;
        uint64_t offset = 0;
        auto section = [&](const char* tag, const std::string& tag_attrs, std::initializer_list<StreamArray*> arrays) {
            xml << "      <" << tag << tag_attrs << ">\n";
            for (StreamArray* a : arrays) {
                xml << "        <DataArray " << a->attributes() << " format=\"appended\" offset=\"" << offset << "\"/>\n";
                offset += a->encoded_size();
            }
            xml << "      </" << tag << ">\n";
        };
        const bool big = std::endian::native == std::endian::big;
        xml << "<?xml version=\"1.0\"?>\n"
            << "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\""
            << (big ? "BigEndian" : "LittleEndian") << "\" header_type=\"UInt64\""
            << compressor_attribute(opt_.compression) << ">\n"
            << "  <UnstructuredGrid>\n"
            << "    <Piece NumberOfPoints=\"" << np_ << "\" NumberOfCells=\"" << nt_ << "\">\n";
        section("PointData", " Scalars=\"" + name_ + "\"", {values_.get()});
        std::vector<StreamArray*> cell_arrays;
        if (checks_.level()) cell_arrays.push_back(level_.get());
        if (checks_.error()) cell_arrays.push_back(error_.get());
        xml << "      <CellData" << (cell_arrays.empty() ? "" : " Scalars=\"level\"") << ">\n";
        for (StreamArray* a : cell_arrays) {
            xml << "        <DataArray " << a->attributes() << " format=\"appended\" offset=\"" << offset << "\"/>\n";
            offset += a->encoded_size();
        }
        xml << "      </CellData>\n";
        section("Points", "", {points_.get()});
        section("Cells", "", {connectivity_.get(), offsets_.get(), types_.get()});
        xml << "    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";
        out_.write(xml.str());
        for (StreamArray* a : all())
            if ((a != level_.get() || checks_.level()) && (a != error_.get() || checks_.error())) a->write_to(out_);
        out_.write(std::string_view("\n  </AppendedData>\n</VTKFile>\n"));
        out_.commit();
    }

private:
    std::array<StreamArray*, 7> all() const {
        return {values_.get(), level_.get(), error_.get(), points_.get(), connectivity_.get(), offsets_.get(),
                types_.get()};
    }

    template <class I>
    void push_cells(std::span<const std::array<uint32_t, 4>> tets, uint64_t first) {
        std::vector<I> conn(4 * tets.size()), offs(tets.size());
        for (std::size_t i = 0; i < tets.size(); ++i) {
            for (int k = 0; k < 4; ++k) conn[4 * i + k] = static_cast<I>(tets[i][k]);
            offs[i] = static_cast<I>(4 * (first + i + 1));
        }
        connectivity_->push_values(std::span<const I>(conn));
        offsets_->push_values(std::span<const I>(offs));
    }

    std::string path_;
    VtuWriteOptions opt_;
    AtomicFile out_;
    std::string name_;
    std::size_t np_ = 0;
    uint64_t nt_ = 0;
    bool wide_ = false;
    StreamedTetChecks checks_;
    std::unique_ptr<StreamArray> values_, level_, error_, points_, connectivity_, offsets_, types_;
};

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

std::unique_ptr<TetMeshSink> open_vtu_stream(const std::string& path, const VtuWriteOptions& options) {
    return std::make_unique<VtuSink>(path, options);
}

void write_vtu(const TetMesh& mesh, const std::string& path, const VtuWriteOptions& options) {
    validate(mesh, "cannot write '" + path + "'");
    VtuSink sink(path, options);
    sink.begin(mesh, mesh.tets.size());
    sink.add(mesh.tets, mesh.level, mesh.error);
    sink.finish();
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
    f.open_stream = [](const std::string& path, const MeshWriteOptions& o) {
        VtuWriteOptions vo;
        vo.compression = o.compression;
        vo.compression_level = o.compression_level;
        return open_vtu_stream(path, vo);
    };
    return f;
}

}  // namespace tetlod
