#pragma once
// .tlod containers: write one from a volume (the HT, the MT or both, with
// provenance and user metadata), inspect one (what `tetlod info` prints),
// extract a LOD mesh from one (the HT lazily: only the chunks the query
// examines are read), and decode one back to its volume.
//
// Trust: every reading call (container_models, inspect_container,
// extract_from_container, decode_container) is safe on untrusted files: a
// malformed, truncated or hostile file gives an Error (returned, never thrown)
// whose message names the file; memory stays bounded by the sizes the file
// declares and the format's limits. write_container works on a trusted
// in-memory Volume.
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"
#include "tetlod/models/lod_model.hpp"
#include "tetlod/models/lod_query.hpp"
#include "tetlod/models/mt/mt_shape_cap.hpp"

namespace tetlod {

// ---- writing ----

class HtErrorSource;      // codecs/ht/ht_codec.hpp
struct HtEncodeOptions;  // codecs/ht/ht_codec.hpp

struct ContainerWriteOptions {
    bool ht = true, mt = false;  // models to store (at least one)
    bool pad = false;            // HT: embed the data in the enclosing (2^k+1)^3 cube
    /// zstd level of every frame, 1..22: whole sections and the HT chunks'
    /// fallback frames (spec §6.4 samples mode). Below 19 encodes faster for
    /// larger files (docs/archival.md, "zstd level").
    int zstd_level = 19;
    /// MT: zstd level of its streams above 1 MiB raw, no higher than zstd_level;
    /// 0: zstd_level. Level 19 on them costs about 2 CPU s per MB for some 5 %
    /// (257^3: 278 CPU s at 19, 34 at 12, for 5.4 % more MT bytes; docs/mt.md §5).
    int mt_large_stream_zstd_level = 12;
    /// HT: bricks of cycle t span 2^(t+1+N) grid steps, 1..16; 0: automatic
    /// (auto_brick_log2 of the volume's dims).
    int brick_log2 = 0;
    int error_bits = 4;          // HT: mantissa bits of stored error bounds, 0..7
    /// MT: mantissa bits of stored error bounds, 0..7 (each bound rounded up,
    /// so at most 2^-N too high). Fewer bits store less (a float MT about 8%
    /// less at 3) for a few % more tets at a given error (docs/mt.md §5).
    int mt_error_bits = 7;
    /// MT: refuse collapses whose new tets have a circumradius / shortest edge
    /// ratio above this (no slivers, a few % more tets; mt_shape_cap.hpp); 0: no cap.
    double mt_max_shape_ratio = kDefaultMtMaxShapeRatio;
    /// Provenance recorded in the metadata: the source file (name, size, XXH64,
    /// when `source_path` names a readable file), the converter and the time.
    std::string source_path;
    std::string converter = "tetlod";
    /// Creation time recorded (seconds since the Unix epoch). Unset: the
    /// environment's SOURCE_DATE_EPOCH when set (the reproducible-builds
    /// convention: the same input and options then give the same bytes; a value
    /// that is not a non-negative decimal integer is InvalidArgument), else now.
    std::optional<int64_t> created;
    /// Out-of-core writing (the VolumePlanes overload): the memory the HT
    /// encoder plans for, in bytes; 0: default_memory_budget().
    std::size_t memory_bytes = 0;
    /// Called as (stage, done, total) while building and encoding: "build MT"
    /// as the MT's bricks complete (done of total work units, first 0, last
    /// done == total; see MtBuildOptions::progress: from TBB worker threads, one
    /// call at a time), "built MT", "build HT", "built HT", "encoded HT",
    /// "encode MT" and "encoded MT" (done = total = 0: the MT's streams are
    /// compressed, some 30 s for 257^3 points), and "encode HT" after each chunk
    /// (done of total chunks).
    std::function<void(const std::string& stage, std::size_t done, std::size_t total)> progress;
    /// Distributed conversion (tetlod-mpi, the VolumePlanes overload, HT only):
    /// the value range and errors computed by several processes
    /// (codecs/ht/ht_distributed.hpp), so the encoder reads the planes once
    /// and sweeps nothing. Null: computed here. Not owned.
    HtErrorSource* ht_errors = nullptr;
    /// Error-bounded lossy archival (format 3.1, spec §5.1), in field units:
    /// > 0 stores a field whose every sample is within max_error of the
    /// original (quantized, then coded losslessly) and error bounds stated
    /// against the original (readers add max_error). HT only (with the MT:
    /// InvalidArgument). 0: lossless, the same bytes as without it. Integer
    /// volumes honour (and state) floor(max_error); below 1 they stay lossless.
    /// The volume is read whole when lossy_reads_whole() says it fits
    /// memory_bytes (the best of three fields is kept); otherwise the
    /// VolumePlanes overload streams two (lossless, lattice) and keeps the smaller.
    double max_error = 0;
    /// The section table's layout: compact (format 3.2, spec §4.4, the
    /// smallest) or full (48-byte entries, for readers older than 3.2: it
    /// also turns range_2d off, so a lossless HT file is a 3.0 file, byte for
    /// byte what they wrote; a lossy one 3.1, or 3.3 with lattice chunks, 3.5
    /// with an MT).
    tlod::TableLayout table = tlod::TableLayout::compact;
    /// HT field chunks may use range-2d (chunk mode 5, format 3.6, spec §7.6)
    /// where it saves bytes, and error chunks range-exp (chunk mode 7, format
    /// 3.8, spec §8.4), with the compact table only; false writes only what
    /// 3.0-3.5 readers read.
    bool range_2d = true;
    /// HT field chunks in the modes that decode fast: static-table rANS (chunk
    /// mode 6, format 3.7, spec §7.6), or constant, zero-residual or samples
    /// where they apply or are smaller. Decodes several times faster, for a
    /// larger file (docs/archival.md, "Fast decoding"). Needs the compact
    /// table and an HT (else InvalidArgument).
    bool fast_decode = false;
};

struct ContainerWriteSummary {
    uint64_t bytes = 0;                   // size of the container written (0 for "-")
    int ht_k = -1, ht_max_level = -1;     // HT: L = 2^k, levels 0..max_level (-1: no HT)
    uint64_t mt_updates = 0, mt_base_tets = 0;
    double seconds = 0;
    /// The bound stated in a lossy container (stored_max_error of the option; 0: lossless).
    double max_error = 0;
};

/// A quarter of the machine's physical memory (at least 256 MiB): what
/// out-of-core conversion plans for unless told otherwise.
std::size_t default_memory_budget();

/// The METADATA write_container records for a volume with this header (its
/// value range left at {0, 0}: the encoder's first pass sets it), with the
/// provenance of `options`; for writers that assemble the container
/// themselves (tetlod-mpi), so they record exactly the same keys.
tlod::Metadata container_metadata(const Volume& header, const ContainerWriteOptions& options);
/// The HT encoder's options write_container uses for `options` and a volume
/// with this header (which settles an automatic brick size).
HtEncodeOptions container_ht_encode_options(const ContainerWriteOptions& options, const Volume& header);

/// The brick size ContainerWriteOptions::brick_log2 = 0 stands for: 5 (bricks
/// of 64 grid steps at the finest cycle) when no axis has more than 129
/// samples, else 4 (32 steps). Each chunk's coder contexts start afresh, so
/// larger bricks code smaller (bucky 128^3 -2.5 %, iron 68^3 -5.9 %:
/// docs/archival.md), while on a volume this small a query that reads whole
/// 64-step bricks reads little; larger volumes keep the finer bricks, whose
/// reads follow the region a query touches.
int auto_brick_log2(const Dims& dims);

/// Whether a lossy conversion (max_error > 0) of a volume with this header is
/// done in memory within `memory_bytes` (0: default_memory_budget()): the
/// volume, two quantized copies and a model's bounds, about 4 (value size + 1)
/// bytes a point. Then the best of three fields is kept: lossless, one
/// following the coder's predictions, one on a lattice. Otherwise the
/// VolumePlanes overload streams the lossless and the lattice fields to
/// candidate files beside the output and keeps the smaller (the prediction-
/// following field needs the whole volume in the coder's order).
bool lossy_reads_whole(const Volume& header, std::size_t memory_bytes);

/// The same container written from a volume read plane by plane: with the
/// HT alone, in memory bounded by options.memory_bytes rather than by the
/// volume (two passes over the planes; same bytes as the overload below;
/// progress stages "scan HT" and "encode HT" over planes, then "encoded HT").
/// With the MT the planes are read into memory first (the MT is built whole).
/// Lossy: see lossy_reads_whole (the same bytes as the overload below when it
/// holds).
ContainerWriteSummary write_container(VolumePlanes& source, const std::string& path,
                                      const ContainerWriteOptions& options = {});

/// Builds the requested models of `volume` (moved in; user metadata from
/// volume.metadata) and writes them to `path` atomically ("-": standard output).
/// Throws tetlod::Error: InvalidArgument for bad options, IoError naming `path`.
ContainerWriteSummary write_container(Volume volume, const std::string& path,
                                      const ContainerWriteOptions& options = {});

// ---- inspecting ----

/// Which models a container holds; both false when it cannot be opened (the
/// reader used next reports why). Reads only the header and section table.
struct ContainerModels {
    bool ht = false, mt = false;
};
ContainerModels container_models(const std::string& path);

/// True when `path` names a .tlod container: its first bytes are the container
/// magic, or (missing or unreadable) it ends in ".tlod".
bool is_container_path(const std::string& path);

struct HtCycleInfo {
    int cycle = 0;
    std::string levels;  // "corners" or "L0..L2"
    uint64_t chunks = 0, points = 0, field_bytes = 0, error_bytes = 0, raw_bytes = 0;
};
struct HtInfo {
    int k = 0;
    int32_t L = 1;
    std::array<int32_t, 3> box_max{0, 0, 0};
    bool padded = false;
    int max_level = 0;
    int brick_log2 = 0, error_mantissa_bits = 0;
    uint64_t section_bytes = 0;
    std::vector<HtCycleInfo> cycles;  // coarsest (cycle k) first
};
struct MtInfo {
    uint32_t base_tets = 0, updates = 0;
    int error_mantissa_bits = 0;
    bool field_from_ht = false;  // the MT shares the HT's field sections
    uint64_t header_bytes = 0, structure_bytes = 0, section_bytes = 0;
};
/// The sections of one type coded one way, summed (issue 13: where the bytes
/// go). The coder follows from the section's type, its ZSTD flag and, for the
/// HT chunks, the HT_HEADER's Residual_Coding and (coding 3, format 3.0) the
/// chunk mode in the table flags: one row per section type and coder (so per
/// mode), known without decoding anything.
struct SectionCoderInfo {
    uint32_t type = 0;        // tlod::SectionType (or an unknown id)
    std::string section;      // tlod::section_type_name(type)
    /// Short stable id: "stored", "zstd", "ht-range-v2" (HT_FIELD, HT_ERRORS of
    /// coding 2), "ht-planes-v1" (coding 1 byte planes; "+zstd" when flagged),
    /// "mt-zstd-payload" (MT_STRUCTURE), "unknown"; coding 3 chunk modes:
    /// "ht-range-v2", "ht-constant", "ht-samples+zstd", "ht-samples",
    /// "ht-zero-residual", "ht-lattice" (3.3), "ht-range-2d" (3.6), "ht-static-rans" (3.7),
    /// "ht-range-exp" (3.8).
    std::string coder;
    /// Coding 3 HT chunks: the chunk mode ("range", "constant", "samples",
    /// "zero-residual", "lattice", "range-2d", "static", "range-exp"); empty for every other section.
    std::string mode;
    std::string description;  // one line for people, naming the spec section
    uint64_t count = 0;       // sections of this type
    uint64_t empty = 0;       // of them, with no stored bytes (empty chunks; not zero-residual ones)
    uint64_t stored_bytes = 0, raw_bytes = 0;
};
/// One row per section type (and coder) present, in the order the types first
/// appear in the file, the rows of one type together. `ht_residual_coding`: the HT_HEADER's Residual_Coding (0: no HT).
std::vector<SectionCoderInfo> section_coders(const std::vector<tlod::SectionInfo>& sections,
                                             int ht_residual_coding);
/// The coder id of one section (as in SectionCoderInfo::coder).
std::string section_coder(const tlod::SectionInfo& section, int ht_residual_coding);
/// The chunk mode of an HT chunk section of coding 3 (as SectionCoderInfo::mode).
std::string section_mode_name(const tlod::SectionInfo& section, int ht_residual_coding);

/// Everything `tetlod info` shows: header, metadata, models, section table.
struct ContainerInfo {
    std::string path;
    tlod::Header header;
    tlod::Metadata metadata;  // of the HT when present, else of the MT
    std::optional<HtInfo> ht;
    std::optional<MtInfo> mt;
    std::vector<tlod::SectionInfo> sections;
    std::vector<SectionCoderInfo> coders;  // section_coders(sections, ...)
    int ht_residual_coding = 0;            // HT_HEADER's, 0 without an HT
    /// Format 3.1 lossy container: every stored sample within max_error of the
    /// original, error bounds stated against the original; 0: lossless.
    double max_error = 0;
    uint64_t bytes_read = 0;  // bytes the inspection read from the file
    /// A format key of the metadata, empty when absent.
    std::string format_key(const std::string& key) const;
};
/// Reads the header, table and model headers (no field data). A container
/// holding no model is a NotFound error.
Expected<ContainerInfo> inspect_container(const std::string& path);

// ---- extracting ----

/// Sets the query's thresholds once the container's value range is known
/// (e.g. thresholds given as a percentage of the range).
using ThresholdResolver = std::function<void(LodQuery& query, const std::array<double, 2>& range)>;

struct ContainerExtract {
    TetMesh mesh;
    ModelKind model = ModelKind::Ht;
    Dims dims;                 // of the data, as the metadata gives them
    ValueType type = ValueType::U8;
    std::array<double, 2> range{0, 0};
    LodQuery query;            // as resolved
    uint64_t tet_count = 0, vertex_count = 0;  // of the mesh (also when streamed)
    double seconds = 0;        // open + read + extract
    double refine_seconds = 0; // HT: the split set (reading what it examines)
    double emit_seconds = 0;   // HT: the tets, handed over (written, when streamed)
    // The largest error of the mesh (HT and MT); HT (lazy): what was read.
    double max_error = 0;
    /// A lossy container's field.max_error E (0: lossless). Every bound above
    /// holds against the original; none is below E (the finest mesh honours E),
    /// so a threshold under E gives the finest mesh and is not met.
    double field_max_error = 0;
    uint64_t bytes_read = 0, file_size = 0;
    uint64_t distinct_bytes_read = 0;  // bytes_read with each section counted once (at most file_size)
    uint64_t chunks_decoded = 0, chunks_total = 0, passes = 0;
    uint64_t chunk_decodes = 0;      // decodings (a chunk evicted and needed again counts again)
    std::size_t cache_peak_bytes = 0; // largest content of the decoded-chunk cache
    // MT: vertex splits of the model, and where its field came from.
    uint64_t mt_updates = 0;
    bool mt_field_from_ht = false;
};

struct ContainerExtractOptions {
    /// HT: budget of the decoded-chunk cache (a query examining more decodes
    /// chunks again: same mesh, more time).
    std::size_t cache_bytes = std::size_t{1024} << 20;
    /// HT: called as chunks are decoded with (distinct chunks decoded, chunks
    /// in the file), from the decoding thread, one call at a time.
    std::function<void(uint64_t decoded, uint64_t total)> progress;
};

/// The mesh of `query` from the container's `model`: the HT lazily (one
/// refinement pass decoding only the chunks the query examines, through a
/// bounded cache; nothing per grid point), the MT decoded whole.
/// `resolve` (optional) fills the thresholds from the value range first.
Expected<ContainerExtract> extract_from_container(const std::string& path, ModelKind model,
                                                  LodQuery query,
                                                  const ThresholdResolver& resolve = {},
                                                  const ContainerExtractOptions& options = {});
/// The same, handing the mesh to `sink` in parts (the HT streams: memory does
/// not grow with the tets; the MT is extracted whole, then handed over). The
/// result's mesh stays empty; tet_count and vertex_count say what was sent.
Expected<ContainerExtract> extract_from_container_to(const std::string& path, ModelKind model, LodQuery query,
                                                     TetMeshSink& sink, const ThresholdResolver& resolve = {},
                                                     const ContainerExtractOptions& options = {});

// ---- decoding ----

/// The volume a container stores, bit-exact: same value type, spacing, origin,
/// field name, units and user metadata (from the HT's field, or an MT-only
/// container's MT field).
/// `progress` (optional) is called as chunks are decoded: (done, total).
Expected<Volume> decode_container(const std::string& path,
                                  const std::function<void(uint64_t done, uint64_t total)>& progress = {});

/// The same volume read plane by plane: from the HT, a row of the finest bricks
/// at a time (memory: that row plus `cache_bytes` of coarser chunks, 0: what a
/// row needs, whatever the grid; write_volume(planes, ...) then streams it to
/// raw, NRRD or MetaImage); an MT-only container's field is decoded whole first.
Expected<std::unique_ptr<VolumePlanes>> open_container_planes(const std::string& path, std::size_t cache_bytes = 0);

/// A container's stored `model` together with the volume it stores, decoding
/// the field once (what open_model + decode_container would give). An MT request
/// on a container without one is a NotFound error naming the file.
struct StoredModel {
    LodModel model;
    Volume volume;
};
Expected<StoredModel> open_stored_model(const std::string& path, ModelKind model);

}  // namespace tetlod
