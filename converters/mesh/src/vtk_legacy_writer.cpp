// Legacy VTK writer ("VTK File Formats", simple legacy formats): a text header
// and BINARY sections, which the format defines as big-endian whatever the host.
// We write the version 3.0 layout (CELLS with a 32-bit count per cell) because
// every VTK reader since the 1990s accepts it.
#include <algorithm>
#include <bit>
#include <cctype>
#include <cstring>
#include <limits>
#include <memory>
#include <span>
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

// Collects values as big-endian bytes.
class BigEndianBuffer {
  public:
    template <class T>
    void put(T v) {
        std::byte b[sizeof(T)];
        std::memcpy(b, &v, sizeof(T));
        if constexpr (std::endian::native == std::endian::little) std::reverse(b, b + sizeof(T));
        bytes_.insert(bytes_.end(), b, b + sizeof(T));
    }
    std::size_t size() const { return bytes_.size(); }
    /// Writes what was put (no line end) and starts over.
    template <class Out>
    void drain_to(Out& out) {
        out.write(bytes_.data(), bytes_.size());
        bytes_.clear();
    }
    /// drain_to, then the line end that closes a binary section.
    void flush_to(AtomicFile& out) {
        drain_to(out);
        out.write(std::string_view("\n"));
    }

  private:
    std::vector<std::byte> bytes_;
};

constexpr std::size_t kDrainBytes = std::size_t{1} << 20;

// Legacy data names are whitespace-delimited tokens.
std::string legacy_name(const std::string& s) {
    std::string r = s.empty() ? "value" : s;
    for (char& c : r)
        if (std::isspace(static_cast<unsigned char>(c))) c = '_';
    return r;
}

// Legacy type names of the sample types (VTK's legacy reader knows them all).
const char* legacy_type_name(ValueType t) {
    switch (t) {
        case ValueType::U8: return "unsigned_char";
        case ValueType::I8: return "char";
        case ValueType::U16: return "unsigned_short";
        case ValueType::I16: return "short";
        case ValueType::U32: return "unsigned_int";
        case ValueType::I32: return "int";
        case ValueType::F32: return "float";
        case ValueType::F64: return "double";
    }
    return "double";
}

/// The streaming legacy writer: points and cells go to the file as they come;
/// the sections after the cells (point data, cell data) wait in temporary
/// files, already in their final big-endian bytes.
class VtkLegacySink final : public TetMeshSink {
public:
    explicit VtkLegacySink(const std::string& path)
        : path_(path), out_(path), values_(path), level_(path), error_(path) {}

    void begin(const TetMesh& v, uint64_t tet_count) override {
        validate_vertices(v, "cannot write '" + path_ + "'");
        np_ = v.points.size();
        nt_ = tet_count;
        constexpr auto kIntMax = static_cast<uint64_t>(std::numeric_limits<int32_t>::max());
        if (np_ > kIntMax || 5 * nt_ > kIntMax)
            throw Error(ErrorCode::TooLarge, "cannot write '" + path_ + "': " + std::to_string(nt_) +
                                                 " tets exceed the legacy .vtk format's 32-bit cell "
                                                 "array; write .vtu instead");
        out_.write(
            "# vtk DataFile Version 3.0\ntetlod tetrahedral mesh\nBINARY\n"
            "DATASET UNSTRUCTURED_GRID\nPOINTS " +
            std::to_string(np_) + " double\n");
        BigEndianBuffer buf;
        for (const auto& p : v.points) {
            for (double c : v.geometry.world(p)) buf.put(c);
            if (buf.size() >= kDrainBytes) buf.drain_to(out_);
        }
        buf.flush_to(out_);
        // The values in the mesh's sample type (exact: they came from it).
        point_data_header_ = "POINT_DATA " + std::to_string(np_) + "\nSCALARS " + legacy_name(v.field_name) + " " +
                             legacy_type_name(v.value_type) + " 1\nLOOKUP_TABLE default\n";
        dispatch_value_type(v.value_type, [&](auto tag) {
            using T = decltype(tag);
            for (double x : v.values) {
                buf.put(static_cast<T>(x));
                if (buf.size() >= kDrainBytes) buf.drain_to(values_);
            }
        });
        buf.drain_to(values_);
        out_.write("CELLS " + std::to_string(nt_) + " " + std::to_string(5 * nt_) + "\n");
        checks_.begin("cannot write '" + path_ + "'", np_, nt_);
    }

    void add(std::span<const std::array<uint32_t, 4>> tets, std::span<const uint8_t> level,
             std::span<const float> error) override {
        checks_.batch(tets, level.size(), error.size());
        BigEndianBuffer buf;
        for (const auto& t : tets) {
            buf.put(int32_t{4});
            for (uint32_t v : t) buf.put(static_cast<int32_t>(v));
        }
        buf.drain_to(out_);
        for (uint8_t v : level) buf.put(v);
        buf.drain_to(level_);
        for (float v : error) buf.put(v);
        buf.drain_to(error_);
    }

    void finish() override {
        checks_.finish();
        out_.write(std::string_view("\n"));
        out_.write("CELL_TYPES " + std::to_string(nt_) + "\n");
        BigEndianBuffer buf;
        for (uint64_t i = 0; i < nt_; ++i) {
            buf.put(int32_t{10});  // VTK_TETRA
            if (buf.size() >= kDrainBytes) buf.drain_to(out_);
        }
        buf.flush_to(out_);
        out_.write(point_data_header_);
        values_.copy_to(out_);
        out_.write(std::string_view("\n"));
        // Cell arrays go in one FIELD block: VTK's legacy reader loads only the first
        // SCALARS of a section unless told ReadAllScalarsOn(), but every FIELD array.
        const int arrays = int{checks_.level()} + int{checks_.error()};
        if (arrays > 0) {
            out_.write("CELL_DATA " + std::to_string(nt_) + "\nFIELD FieldData " + std::to_string(arrays) + "\n");
            if (checks_.level()) {
                out_.write("level 1 " + std::to_string(nt_) + " unsigned_char\n");
                level_.copy_to(out_);
                out_.write(std::string_view("\n"));
            }
            if (checks_.error()) {
                out_.write("error 1 " + std::to_string(nt_) + " float\n");
                error_.copy_to(out_);
                out_.write(std::string_view("\n"));
            }
        }
        out_.commit();
    }

private:
    std::string path_;
    AtomicFile out_;
    SpillFile values_, level_, error_;
    std::string point_data_header_;
    std::size_t np_ = 0;
    uint64_t nt_ = 0;
    StreamedTetChecks checks_;
};

}  // namespace

std::unique_ptr<TetMeshSink> open_vtk_legacy_stream(const std::string& path) {
    return std::make_unique<VtkLegacySink>(path);
}

void write_vtk_legacy(const TetMesh& mesh, const std::string& path) {
    validate(mesh, "cannot write '" + path + "'");
    send_mesh(mesh, *open_vtk_legacy_stream(path));
}

MeshFormat vtk_legacy_mesh_format() {
    MeshFormat f;
    f.name = "vtk";
    f.extensions = {".vtk"};
    f.description = "(VTK legacy)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) { write_vtk_legacy(m, path); };
    f.open_stream = [](const std::string& path, const MeshWriteOptions&) { return open_vtk_legacy_stream(path); };
    return f;
}

}  // namespace tetlod
