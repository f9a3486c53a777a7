#pragma once
// The MT in a .tlod container (spec/tlod-format.md §10): an MT_HEADER and an
// MT_STRUCTURE section after the HT's sections. Next to an HT the MT shares its
// lossless field (the HT_FIELD sections) and is an optional feature that older
// readers skip; alone, it carries the field in its own payload and is required.
#include <cstdint>
#include <string>

#include "tetlod/codecs/mt/mt_codec.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

namespace tetlod {

/// Appends the MT sections. With `with_ht` the writer must already hold the
/// HT of the same volume (encode_ht); otherwise METADATA is written first and the
/// field goes into the MT payload. Sets the features. Throws tetlod::Error.
/// Next to a lossy HT (format 3.1, spec §5.1) the model must be built on the
/// HT's stored field and options.field_error be its E: the stored update errors
/// then hold against the original. An MT alone is never lossy.
void encode_mt_container(const MtModel& model, const tlod::Metadata& meta, tlod::ContainerWriter& writer,
                         bool with_ht, const MtEncodeOptions& options = {});

/// What the MT sections say, validated against METADATA (reads only METADATA
/// and MT_HEADER). Safe on untrusted input.
struct MtLayout {
    tlod::Metadata metadata;
    bool with_ht = false;         // the field comes from the HT sections
    std::size_t header_section = 0;
    std::size_t structure_section = 0;
    uint32_t base_tets = 0;
    uint32_t updates = 0;
    int error_mantissa_bits = 0;
};
Expected<MtLayout> read_mt_layout(tlod::ContainerReader& reader);

/// Decodes the MT (and, when it shares the HT's field, the HT field). Safe on untrusted input.
Expected<MtModel> decode_mt_container(tlod::ContainerReader& reader);

/// Loads the MT of a .tlod file. Throws tetlod::Error naming the file.
MtModel load_mt_model(const std::string& path);

/// True when the container holds an MT (required or optional feature bit).
bool container_has_mt(const tlod::ContainerReader& reader);

}  // namespace tetlod
