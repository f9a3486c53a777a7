#pragma once
// The HT in a .tlod container (spec/tlod-format.md §6-§8): the field stored
// losslessly as residuals of a coarse-to-fine prediction, per-diamond errors
// quantized upward to a truncated float32 (so a stored bound is never below the
// true one), both split into chunks by cycle (3 levels) and by spatial brick so
// a coarse LOD reads a prefix of the file and a box reads few bricks.
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "tetlod/codecs/error_quantizer.hpp"
#include "tetlod/models/ht/ht_error_sweep.hpp"
#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/models/ht/ht_sample_source.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/volume_planes.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

namespace tetlod {

struct HtEncodeOptions {
    int zstd_level = 19;
    /// Bricks of cycle t span 2^(t+1+brick_log2) grid steps per axis (spec §6.2).
    int brick_log2 = 4;
    /// Mantissa bits kept by the error quantizer, 0..7 (spec §8): the stored
    /// bound exceeds the true error by less than a factor 1 + 2^-m.
    int error_mantissa_bits = 4;
    /// Chunk modes (spec §6.4): -1 codes every chunk section in the smallest
    /// mode (range-2d only when it saves 4 bytes); 0 range, 1 constant, 2
    /// samples, 3 zero-residual, 4 lattice (field chunks of lossy files whose
    /// values are all on the step's lattice, format 3.3), 5 range-2d (field
    /// chunks, format 3.6), 6 static (field chunks of at most 2^22 points,
    /// format 3.7), 7 range-exp (error chunks, format 3.8) force that mode
    /// wherever it can code the chunk (tests), range elsewhere.
    int chunk_mode = -1;
    /// zstd level of the samples mode (the per-chunk fallback).
    int chunk_zstd_level = 19;
    /// Format 3.1 lossy archival (spec §5.1): > 0 marks the file LOSSY with
    /// field.max_error = E. The field given to the encoder must already be
    /// within E of the original (quantize_predicted, quantize_volume); the errors
    /// coded are those of that field, readers add E.
    double max_error = 0;
    /// The section table's layout (spec §4.4): compact (format 3.2) or full
    /// (48-byte entries, for 3.0/3.1 readers, with range_2d false). encode_ht
    /// sets it on its writer.
    tlod::TableLayout table = tlod::TableLayout::compact;
    /// Field chunks may be coded in range-2d (chunk mode 5, format 3.6) where it
    /// is smaller; false writes only modes that 3.0-3.5 readers know.
    bool range_2d = true;
    /// Field chunks in the modes that decode fast: static-table rANS (chunk mode
    /// 6, format 3.7, spec §7.6), or constant, zero-residual, samples where
    /// they apply or are smaller. Several times faster to decode, larger
    /// (docs/archival.md, "Fast decoding"). Error chunks are unchanged. Needs the
    /// compact table.
    bool fast_decode = false;
    /// Error chunks coded in range-exp (chunk mode 7, format 3.8, spec §8.4):
    /// contexts from the lattice bound's exponent, up to 35 % fewer error bytes.
    /// False writes only what 3.0-3.7 readers read (as range_2d, the caller
    /// sets it with the table it wants: container writes turn both off with
    /// the full one).
    bool range_exp = true;
    /// Called with (chunks done, chunks total) from the calling thread.
    std::function<void(std::size_t, std::size_t)> progress;
    /// > 0: encode_ht stops and returns false as soon as its chunk sections
    /// alone reach this many bytes (the file is then certain to), leaving the
    /// writer incomplete (write_ht_container then throws, writing nothing).
    /// For callers keeping the smallest of several encodings: a candidate that
    /// cannot win is not finished. The streaming encoders ignore it.
    uint64_t give_up_at = 0;
};

/// Lossy archival (format 3.1, spec §5.1): replaces, in place, every sample of
/// an unpadded volume by a value within E of it (integers: within floor(E)),
/// chosen as the HT coder's own prediction plus a multiple of the step
/// (integers 2*floor(E)+1, floats 2E), visiting the points in coding order so
/// that the encoder with this brick_log2 codes zero residuals wherever the
/// prediction is within E. The bound holds whatever the coder does.
void quantize_predicted(Volume& volume, int brick_log2, double max_error);

/// Appends METADATA and the HT sections of `model` to `writer` and sets the HT
/// feature. `meta` describes the original (unpadded) volume. False when it
/// gave up (options.give_up_at), true otherwise.
bool encode_ht(const HtModel& model, const tlod::Metadata& meta, tlod::ContainerWriter& writer,
               const HtEncodeOptions& options = {});
/// encode_ht + atomic write. Throws tetlod::Error.
void write_ht_container(const std::string& path, const HtModel& model, const tlod::Metadata& meta,
                        const HtEncodeOptions& options = {});

/// Errors computed elsewhere (a distributed conversion, ht_distributed.hpp):
/// the streaming encoder then skips its first pass and its error sweep, reads
/// the planes once and asks for the errors of each slab instead.
class HtErrorSource {
public:
    virtual ~HtErrorSource() = default;
    /// The value range of the whole volume (what the first pass would find).
    virtual std::array<double, 2> range() const = 0;
    /// Puts into `sink` the errors of every cycle t < k centred in planes
    /// za..zb of the data box (slabs come in order; whole lattice planes).
    virtual void fill(int64_t za, int64_t zb, HtErrorPlaneSink& sink) = 0;
};

/// Out-of-core conversion: the HT container of a volume read plane by plane.
struct HtStreamEncodeOptions {
    HtEncodeOptions encode;  // its progress callback is not used: see `progress`
    /// Embed the data in the enclosing (2^k+1)^3 cube (HtBuildOptions::pad).
    bool pad = false;
    /// Memory the encoder plans for, in bytes (its peak, buffers and
    /// bookkeeping; the program itself comes on top). The slab height adapts;
    /// when even one plane at a time does not fit, InvalidArgument says how
    /// much is needed.
    std::size_t memory_bytes = std::size_t{1} << 30;
    /// Planes per slab, 1..1024; 0: the largest power of two up to 64 that fits
    /// the budget. Any height gives the same bytes; higher ones amortise the
    /// per-slab work of the large diamonds and feed more threads.
    int slab_planes = 0;
    /// Called from the calling thread as (stage, done, total): "scan" over the
    /// planes (range, coarse lattice), then "encode" over the planes.
    std::function<void(const char* stage, uint64_t done, uint64_t total)> progress;
    /// Not null: the range and errors come from there (same bytes when they
    /// are those of the volume). Not owned.
    HtErrorSource* errors = nullptr;
};

struct HtStreamEncodeSummary {
    HtDomain domain;
    std::array<double, 2> range{0, 0};
    int slab_planes = 0;            // planes per slab chosen for the budget
    std::size_t planned_bytes = 0;  // the encoder's planned peak
    uint64_t chunks = 0;
};

/// Writes the container of the HT of `source` to `path` atomically ("-":
/// standard output), reading the volume twice, plane by plane, in memory
/// bounded by options.memory_bytes rather than by the volume. The bytes equal
/// those of write_ht_container(HtModel::build(volume, pad), meta, options.encode).
/// `meta` describes the source volume; its value range is replaced by the one
/// read. Chunk payloads wait in a temporary file beside `path`. Throws
/// tetlod::Error: CorruptData for a non-finite value, InvalidArgument for a
/// budget below the minimum, IoError/Truncated from the source or the output.
HtStreamEncodeSummary write_ht_container_streaming(VolumePlanes& source, tlod::Metadata meta,
                                                   const std::string& path,
                                                   const HtStreamEncodeOptions& options = {});

/// The original volume of an HT container, read plane by plane: a row of the
/// finest bricks (2^(brick_log2+1) planes) is decoded at a time, its chunks in
/// parallel, the coarser chunks through a cache of `cache_bytes` (0: what a
/// row needs). Memory: one row of planes plus the cache, whatever the grid. The same samples as
/// decode_volume. Safe on untrusted input: opening validates the layout,
/// read() throws tetlod::Error naming the container and section.
Expected<std::unique_ptr<VolumePlanes>> open_ht_planes(const std::string& path, std::size_t cache_bytes = 0);
/// The same over an open container (a file or bytes in memory).
Expected<std::unique_ptr<VolumePlanes>> open_ht_planes(tlod::ContainerReader reader, std::size_t cache_bytes = 0);

/// One chunk of the HT data: the grid points of one cycle inside one brick.
struct HtChunk {
    int cycle = 0;            // t: points are multiples of 2^t, not all of 2^(t+1)
    uint32_t brick = 0;       // linear brick index within the cycle
    std::array<int64_t, 6> box{};  // inclusive x0,y0,z0,x1,y1,z1 of the brick (clipped to B)
    uint64_t points = 0;      // grid points of the chunk (= field values)
    uint64_t diamonds = 0;    // error codes (= points except in the corner cycle t = k)
    std::size_t field_section = 0;
    std::size_t error_section = 0;
};

/// What the HT sections say, validated against the METADATA (reads only the
/// header, table, METADATA and HT_HEADER sections). Safe on untrusted input.
struct HtLayout {
    tlod::Metadata metadata;
    HtDomain domain;
    int brick_log2 = 0;
    int error_mantissa_bits = 0;
    /// HT_HEADER Residual_Coding: 1 = zigzag byte planes + zstd (format 1.x),
    /// 2 = class-ordered range coding (format 2.x), 3 = a mode per chunk
    /// section, one of them range coding 2 (format 3.x).
    int residual_coding = 2;
    /// Format 3.1, LOSSY feature: every stored sample is within this E of the
    /// original and the decoded error bounds include it (stored code + E);
    /// 0: the field is the original (lossless).
    double max_error = 0;
    std::vector<HtChunk> chunks;  // file order: cycle k first, then k-1, ..., 0
};
Expected<HtLayout> read_ht_layout(tlod::ContainerReader& reader);

/// Which part of the hierarchy to decode.
struct HtDecodeRequest {
    /// Decode cycles >= finest_cycle only (0 = full resolution). Cycle t holds the
    /// centres of diamonds of levels 3(k-1-t) .. 3(k-1-t)+2.
    int finest_cycle = 0;
    /// Decode only chunks needed for this inclusive index box (and their predictors).
    std::optional<std::array<int64_t, 6>> box;
    bool errors = true;
    /// Called after each cycle with (chunks decoded, chunks to decode).
    std::function<void(uint64_t done, uint64_t total)> progress;
};

struct HtDecoded {
    HtLayout layout;
    /// On B (padded when layout.domain.padded). Points not decoded are 0.
    Volume field;
    /// Per grid point of B; points not decoded hold +inf, cube corners 0.
    ZeroedVector<float> errors;
    uint64_t chunks_decoded = 0;
};
/// Decodes (part of) the HT. Safe on untrusted input: every section is checked
/// (checksum, size, zstd frame, code ranges) before its content is used.
Expected<HtDecoded> decode_ht(tlod::ContainerReader& reader, const HtDecodeRequest& request = {});

struct HtLazyStats {
    uint64_t chunks_total = 0;
    uint64_t chunks_decoded = 0;    // distinct chunks decoded
    uint64_t chunk_decodes = 0;     // decodings, counting a chunk evicted and needed again
    std::size_t cache_peak_bytes = 0;
    uint64_t bytes_read = 0;           // from the container, header and table included
    uint64_t distinct_bytes_read = 0;  // the same, a section read twice counted once
    int passes = 0;                    // refinement passes (1)
};
struct HtLazyOptions {
    /// Budget of the decoded-chunk cache. Below what a query examines, chunks
    /// are decoded again: same mesh, more time.
    std::size_t cache_bytes = std::size_t{1024} << 20;
    /// Called after each chunk decoding as (distinct chunks decoded, chunks in
    /// the file), from whichever thread decoded it, one call at a time.
    std::function<void(uint64_t decoded, uint64_t total)> progress;
};
/// The LOD mesh of `query`, equal to the extraction from the fully decoded
/// model, in one refinement pass that decodes on demand only the chunks
/// holding the errors and values it examines (and the coarser chunks those
/// are predicted from). Memory: the cache, plus tables sized by the output;
/// nothing per grid point. Safe on untrusted input.
Expected<TetMesh> extract_ht_lazy(tlod::ContainerReader& reader, const LodQuery& query,
                                  HtExtractStats* stats = nullptr, HtLazyStats* lazy = nullptr,
                                  const HtLazyOptions& options = {});
/// The same mesh handed to `sink` in parts (HtModel::extract_to): memory holds
/// the cache, the split set and one batch of tets. The sink's exceptions
/// (tetlod::Error) come back as the Failure.
/// `share`: one part of it (HtEmitShare, models/ht/ht_sample_source.hpp).
Expected<Done> extract_ht_lazy_to(tlod::ContainerReader& reader, const LodQuery& query, TetMeshSink& sink,
                                  HtExtractStats* stats = nullptr, HtLazyStats* lazy = nullptr,
                                  const HtLazyOptions& options = {}, const HtEmitShare& share = {});

/// The original volume, bit-exact (padding removed), with its metadata restored.
Expected<Volume> decode_volume(tlod::ContainerReader& reader,
                               const std::function<void(uint64_t done, uint64_t total)>& progress = {});

/// Loads the whole HT of a .tlod file as a model ready for extraction (decodes
/// every chunk; lazy loading comes later). Throws tetlod::Error naming the file.
HtModel load_ht_model(const std::string& path);

/// True when the file starts with the .tlod magic (cheap format sniffing).
bool is_tlod_file(const std::string& path);

}  // namespace tetlod
