#pragma once
// VTK writers for extracted tetrahedral meshes, readable by ParaView, VisIt and
// the VTK library:
//  - XML UnstructuredGrid (.vtu), binary appended data with UInt64 headers,
//    optionally compressed in blocks the way VTK's zlib, LZ4 and LZMA data
//    compressors do it (blocks compressed in parallel; the bytes do not depend
//    on the thread count); connectivity and offsets as Int32 when they fit;
//  - legacy (.vtk) BINARY UNSTRUCTURED_GRID, big-endian as that format requires.
// Both carry: points in world coordinates (mesh.geometry applied) as Float64,
// the field as point data named mesh.field_name (in mesh.value_type: a u8
// volume gives UInt8 values; legacy .vtk: the same where it has the type,
// else double), and cell data
// "level" (UInt8) and "error" (Float32) when the mesh has them. Cells are VTK
// tetrahedra (type 10) with the mesh's vertex order, positive in index space.
#include <cstddef>
#include <memory>
#include <string>

#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"

namespace tetlod {

struct VtuWriteOptions {
    /// Block compressor of every array; None stores them raw.
    MeshCompression compression = MeshCompression::Zlib;
    /// 1 (fastest) .. 9 (smallest); 0: the default (zlib 1: fast, see
    /// MeshWriteOptions; LZ4 9, i.e. acceleration 1; LZMA 5, as VTK's writer).
    int compression_level = 0;
    /// Uncompressed bytes per compressed block (VTK's default is 32 KiB).
    std::size_t block_size = 32768;
};

/// Writes `mesh` as a .vtu file, atomically. Throws tetlod::Error:
/// InvalidArgument when the mesh is inconsistent (array sizes, vertex ids out of
/// range), IoError when the file cannot be written.
void write_vtu(const TetMesh& mesh, const std::string& path, const VtuWriteOptions& options = {});
/// The same file written as the parts arrive: memory holds one batch of
/// blocks per array; the encoded arrays wait in temporary files beside `path`
/// until finish() writes the header (which needs their sizes) and them.
std::unique_ptr<TetMeshSink> open_vtu_stream(const std::string& path, const VtuWriteOptions& options = {});

/// Writes `mesh` as a legacy .vtk file (version 3.0 layout, 32-bit cell ids),
/// atomically. Throws like write_vtu, and TooLarge when the mesh exceeds the
/// legacy format's 32-bit cell array.
void write_vtk_legacy(const TetMesh& mesh, const std::string& path);
/// The same file written as the parts arrive (the sections after the cells
/// wait in temporary files beside `path`).
std::unique_ptr<TetMeshSink> open_vtk_legacy_stream(const std::string& path);

}  // namespace tetlod
