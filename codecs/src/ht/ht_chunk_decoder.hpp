#pragma once
// Decoding chosen chunks of an HT (spec §6.3): the dependency closure of a set
// of chunks and their decoding, cycle by cycle, into a field and error array.
#include <cstdint>
#include <string>
#include <vector>

#include "ht_chunk_geometry.hpp"
#include "tetlod/codecs/ht/ht_codec.hpp"

namespace tetlod::ht_detail {

/// Adds to `want` every chunk the wanted ones depend on: per cycle, the coarser
/// chunks meeting the wanted chunks' boxes grown by the predictor reach (2^t
/// at cycle t, spec §6.3). `want` is indexed like L.chunks (file order).
void add_dependencies(const HtLayout& L, std::vector<char>& want);

/// Decodes chunk `c` from its stored sections (read by the caller; consumed)
/// into arrays laid out by `G`: the whole field on B, or the chunk's window
/// (window_for). `errors` null: the field only. Every point the coders read
/// must hold its decoded value. Failure (code Ok on success) names the section.
Failure decode_chunk_sections(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c, const Geometry& G,
                              ValueType type, void* field, float* errors, std::vector<std::byte>& field_stored,
                              std::vector<std::byte>& error_stored);

/// The error half of decode_chunk_sections: chunk `c`'s errors, once the field
/// of its cycle and the coarser ones is decoded (the lattice bounds read it).
Failure decode_chunk_errors(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c, const Geometry& G,
                            ValueType type, const void* field, float* errors, std::vector<std::byte>& error_stored);

/// Decodes the wanted chunks not yet decoded (`done`), cycle by cycle, into
/// `field` / `errors` (errors when non-null). Dependencies must be wanted too.
Expected<uint64_t> decode_chunks(tlod::ContainerReader& r, const HtLayout& L, const std::vector<char>& want,
                                 std::vector<char>& done, Volume& field, ZeroedVector<float>* errors,
                                 const std::function<void(uint64_t, uint64_t)>& progress = {});

/// The zero field on B of `L` and, when `errors` is non-null, one zero error per
/// grid point. Both are untouched zero pages (ZeroedVector) until decoded, so a
/// file that fails in its first chunks costs only the pages decoded so far, not
/// the grid its header claims. TooLarge when memory runs out; messages start
/// with `name` (the container's).
Expected<Volume> allocate_decoded(const std::string& name, const HtLayout& L, ZeroedVector<float>* errors);

/// Spacing, origin, names and user keys of the METADATA on a decoded field.
void restore_metadata(Volume& field, const tlod::Metadata& md);

}  // namespace tetlod::ht_detail
