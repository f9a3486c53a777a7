// Legacy VTK writer ("VTK File Formats", simple legacy formats): a text header
// and BINARY sections, which the format defines as big-endian whatever the host.
// We write the version 3.0 layout (CELLS with a 32-bit count per cell) because
// every VTK reader since the 1990s accepts it.
#include <algorithm>
#include <bit>
#include <cctype>
#include <cstring>
#include <limits>
#include <vector>

#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/converters/vtk_writers.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
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
    void flush_to(AtomicFile& out) {
        out.write(bytes_.data(), bytes_.size());
        out.write(std::string_view("\n"));
        bytes_.clear();
    }

  private:
    std::vector<std::byte> bytes_;
};

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

}  // namespace

void write_vtk_legacy(const TetMesh& mesh, const std::string& path) {
    validate(mesh, "cannot write '" + path + "'");
    const std::size_t np = mesh.points.size();
    const std::size_t nt = mesh.tets.size();
    constexpr auto kIntMax = static_cast<std::size_t>(std::numeric_limits<int32_t>::max());
    if (np > kIntMax || 5 * nt > kIntMax)
        throw Error(ErrorCode::TooLarge, "cannot write '" + path + "': " + std::to_string(nt) +
                                             " tets exceed the legacy .vtk format's 32-bit cell "
                                             "array; write .vtu instead");

    AtomicFile out(path);
    BigEndianBuffer buf;
    out.write(
        "# vtk DataFile Version 3.0\ntetlod tetrahedral mesh\nBINARY\n"
        "DATASET UNSTRUCTURED_GRID\nPOINTS " +
        std::to_string(np) + " double\n");
    for (const auto& p : mesh.points)
        for (double c : mesh.geometry.world(p)) buf.put(c);
    buf.flush_to(out);

    out.write("CELLS " + std::to_string(nt) + " " + std::to_string(5 * nt) + "\n");
    for (const auto& t : mesh.tets) {
        buf.put(int32_t{4});
        for (uint32_t v : t) buf.put(static_cast<int32_t>(v));
    }
    buf.flush_to(out);
    out.write("CELL_TYPES " + std::to_string(nt) + "\n");
    for (std::size_t i = 0; i < nt; ++i) buf.put(int32_t{10});  // VTK_TETRA
    buf.flush_to(out);

    // The values in the mesh's sample type (exact: they came from it).
    out.write("POINT_DATA " + std::to_string(np) + "\nSCALARS " + legacy_name(mesh.field_name) + " " +
              legacy_type_name(mesh.value_type) + " 1\nLOOKUP_TABLE default\n");
    dispatch_value_type(mesh.value_type, [&](auto tag) {
        using T = decltype(tag);
        for (double v : mesh.values) buf.put(static_cast<T>(v));
    });
    buf.flush_to(out);

    // Cell arrays go in one FIELD block: VTK's legacy reader loads only the first
    // SCALARS of a section unless told ReadAllScalarsOn(), but every FIELD array.
    const int arrays = int{!mesh.level.empty()} + int{!mesh.error.empty()};
    if (arrays > 0) {
        out.write("CELL_DATA " + std::to_string(nt) + "\nFIELD FieldData " +
                  std::to_string(arrays) + "\n");
        if (!mesh.level.empty()) {
            out.write("level 1 " + std::to_string(nt) + " unsigned_char\n");
            for (uint8_t v : mesh.level) buf.put(v);
            buf.flush_to(out);
        }
        if (!mesh.error.empty()) {
            out.write("error 1 " + std::to_string(nt) + " float\n");
            for (float v : mesh.error) buf.put(v);
            buf.flush_to(out);
        }
    }
    out.commit();
}

MeshFormat vtk_legacy_mesh_format() {
    MeshFormat f;
    f.name = "vtk";
    f.extensions = {".vtk"};
    f.description = "(VTK legacy)";
    f.write = [](const TetMesh& m, const std::string& path, const MeshWriteOptions&) { write_vtk_legacy(m, path); };
    return f;
}

}  // namespace tetlod
