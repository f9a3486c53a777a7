#pragma once
// The table of tetrahedral mesh formats: one MeshFormat entry per format, each
// defined beside its writer and registered in one list
// (src/mesh_format_registry.cpp). write_tet_mesh, the CLI's --format choices and
// its help texts come from this table.
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"

namespace tetlod {

/// Block compressors of VTK's XML formats (vtkZLibDataCompressor,
/// vtkLZ4DataCompressor, vtkLZMADataCompressor), which every VTK reader knows.
enum class MeshCompression { None, Zlib, Lz4, Lzma };
/// "none", "zlib", "lz4", "lzma".
const char* mesh_compression_name(MeshCompression c);
/// The compression of a name above; nullopt for anything else.
std::optional<MeshCompression> parse_mesh_compression(std::string_view name);

struct MeshWriteOptions {
    /// Compression where the format allows it (.vtu); ignored by the others.
    /// zlib by default, at level 1: every reader knows it (VTK, ParaView,
    /// meshio), and at level 1 it costs a fraction of level 6's time for files
    /// a few percent larger. LZ4 is faster still but only VTK/ParaView read it
    /// (not meshio); LZMA gives the smallest files.
    MeshCompression compression = MeshCompression::Zlib;
    /// The compressor's level, 1 (fastest) .. 9 (smallest); 0: the format's
    /// default (zlib 1 here; see VtuWriteOptions).
    int compression_level = 0;
};

struct MeshFormat {
    /// Name accepted by --format ("vtu", "msh-binary").
    std::string name;
    /// Lower-case extensions with the dot that select this format; empty for a
    /// format chosen only by name (msh-binary: .msh files are ASCII unless asked).
    std::vector<std::string> extensions;
    /// One line for help texts.
    std::string description;
    /// False when this build leaves the format out (write is then empty).
    bool built = true;
    /// Writes atomically; throws tetlod::Error naming the file.
    std::function<void(const TetMesh&, const std::string& path, const MeshWriteOptions&)> write;
    /// Optional: a writer taking the mesh in parts (tet_mesh_sink.hpp), whose
    /// memory does not grow with the tets. Without it, open_mesh_stream
    /// gathers the parts and calls `write` at the end.
    std::function<std::unique_ptr<TetMeshSink>(const std::string& path, const MeshWriteOptions&)> open_stream;
    /// Optional: other files `write` creates beside `path` (Medit's .sol).
    std::function<std::vector<std::string>(const std::string& path)> companion_files;
};

/// Every mesh format in registration order. Entries never move.
const std::deque<MeshFormat>& mesh_formats();

/// Adds a format (a third party's, or a test's). Not thread-safe: call it before
/// other threads write meshes. Throws InvalidArgument when the name or an
/// extension is taken.
void register_mesh_format(MeshFormat format);

/// The format named `name` (case-insensitive), or null.
const MeshFormat* find_mesh_format(const std::string& name);

/// The format `path` selects by its extension (case-insensitive), or null.
const MeshFormat* mesh_format_for_path(const std::string& path);

/// For help texts: ".vtu, .vtk, .msh (Gmsh 4.1), .mesh (Medit + .sol)" from the descriptions.
std::string mesh_format_summary();

}  // namespace tetlod
