#pragma once
// The planes of a NRRD/MetaImage whose samples are spread over several data
// files, or deflate-compressed (gzip or zlib), or after skipped lines: what
// planes_of_pieces cannot read with one offset. Private to tetlod_volume_io.
#include <memory>
#include <string>
#include <vector>

#include "nrrd_metaimage_common.hpp"

namespace tetlod::detail {

/// Raw pieces are read by offset (the start of each found once, after its
/// line skip). Compressed pieces are inflated as a stream that moves forward
/// only: a read ahead of the stream skips forward, a read of bytes already
/// passed restarts that piece's stream from its start, so reading the planes in
/// order costs one pass over the files; the last plane read is kept, so reading
/// it again (padding repeats the last plane) costs nothing. A piece's trailer
/// (CRC-32/Adler-32) is checked when its last byte is read. The first plane
/// of a compressed first piece is inflated here (and thrown away), so a garbage
/// or cut stream fails at open, before anything is allocated for the header's
/// claim. The pieces' sizes
/// must have been checked (check_piece_sizes). Errors name `what` and the data
/// file (Truncated, CorruptData, IoError).
std::unique_ptr<VolumePlanes> open_piece_planes(Volume header, std::vector<DataPiece> pieces,
                                                Compression compression, Endian file_endian,
                                                std::string what);

}  // namespace tetlod::detail
