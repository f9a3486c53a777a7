// Planes of samples over several data files, or compressed. See piece_planes.hpp.
#include "piece_planes.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <optional>

#include "tetlod/core/error.hpp"

namespace tetlod::detail {

namespace {

// One piece's compressed stream, from its start, moving forward.
class Inflater {
  public:
    Inflater(const DataPiece& piece, const std::string& what) : piece_(piece), what_(what) {
        if (piece.byte_skip < 0)
            throw Error(ErrorCode::UnsupportedFeature,
                        what + ": \"byte skip: -1\" is only allowed with raw encoding");
        f_ = open_read(piece.path, what);
        seek_to(f_.get(), piece.file_offset, piece.path);
        skip_lines(f_.get(), piece.line_skip, piece.file_offset, piece.path, what);
        if (inflateInit2(&zs_, 15 + 32) != Z_OK)
            throw Error(ErrorCode::IoError, what + ": cannot initialise zlib");
        try {
            in_.resize(kZChunk);
            discard_.resize(kZChunk);
            skip(uint64_t(piece.byte_skip));  // counted in the decompressed stream
        } catch (...) {
            inflateEnd(&zs_);  // no destructor runs for a constructor that throws
            throw;
        }
        produced_ = 0;
    }
    ~Inflater() { inflateEnd(&zs_); }
    Inflater(const Inflater&) = delete;
    Inflater& operator=(const Inflater&) = delete;

    /// Sample bytes produced so far (after the byte skip).
    uint64_t position() const { return produced_; }

    /// The next n bytes of samples (dst null: thrown away); `declared` is the
    /// piece's sample bytes, for messages.
    void next(std::byte* dst, uint64_t n, uint64_t declared) {
        auto truncated = [&] {
            return Error(ErrorCode::Truncated,
                         what_ + ": data file '" + piece_.path +
                             "' is truncated: it decompresses to " + std::to_string(produced_) +
                             " bytes, but the header declares " + std::to_string(declared));
        };
        while (n > 0) {
            if (zs_.avail_in == 0) fill();
            if (stream_end_) {  // a following gzip member (concatenated streams), or nothing
                if (zs_.avail_in == 0) throw truncated();
                if (inflateReset(&zs_) != Z_OK) throw corrupt();
                stream_end_ = false;
            }
            const uint64_t want = std::min<uint64_t>(n, kZChunk);
            zs_.next_out =
                dst ? reinterpret_cast<Bytef*>(dst) : reinterpret_cast<Bytef*>(discard_.data());
            zs_.avail_out = uInt(want);
            const int rc = inflate(&zs_, Z_NO_FLUSH);
            if (rc == Z_STREAM_END)
                stream_end_ = true;
            else if (rc != Z_OK && rc != Z_BUF_ERROR)
                throw corrupt();
            const uint64_t got = want - zs_.avail_out;
            if (got == 0 && !stream_end_ && zs_.avail_in == 0 && eof_) throw truncated();
            produced_ += got;
            n -= got;
            if (dst) dst += got;
        }
    }

    /// Runs the stream to its end, so its checksum is verified and a cut-off
    /// file is caught (what the whole read does after the last sample).
    void finish() {
        while (!stream_end_) {
            if (zs_.avail_in == 0) fill();
            zs_.next_out = reinterpret_cast<Bytef*>(discard_.data());
            zs_.avail_out = uInt(discard_.size());
            const int rc = inflate(&zs_, Z_NO_FLUSH);
            if (rc == Z_STREAM_END)
                stream_end_ = true;
            else if (rc != Z_OK && rc != Z_BUF_ERROR)
                throw corrupt();
            if (!stream_end_ && zs_.avail_out == discard_.size() && zs_.avail_in == 0 && eof_)
                throw Error(ErrorCode::Truncated,
                            what_ + ": data file '" + piece_.path +
                                "' is truncated: the compressed stream has no end");
        }
    }

  private:
    void skip(uint64_t n) { next(nullptr, n, n); }

    void fill() {
        const std::size_t n = std::fread(in_.data(), 1, in_.size(), f_.get());
        if (n == 0 && std::ferror(f_.get()))
            throw Error(ErrorCode::IoError,
                        what_ + ": cannot read data file '" + piece_.path + "'");
        eof_ = n == 0;
        zs_.next_in = in_.data();
        zs_.avail_in = uInt(n);
    }

    Error corrupt() const {
        return Error(ErrorCode::CorruptData, what_ + ": compressed data in '" + piece_.path +
                                                 "' is corrupt (" +
                                                 (zs_.msg ? zs_.msg : "zlib error") + ")");
    }

    const DataPiece& piece_;
    const std::string& what_;
    FilePtr f_;
    z_stream zs_{};
    std::vector<unsigned char> in_;
    std::vector<std::byte> discard_;
    uint64_t produced_ = 0;
    bool stream_end_ = false, eof_ = false;
};

class PiecePlanes final : public VolumePlanes {
  public:
    PiecePlanes(Volume header, std::vector<DataPiece> pieces, Compression compression,
                Endian endian, std::string what)
        : header_(std::move(header)),
          pieces_(std::move(pieces)),
          compressed_(compression != Compression::None),
          swap_(endian != host_endian()),
          what_(std::move(what)) {
        header_.data = {};
        plane_ = uint64_t(header_.dims.x) * uint64_t(header_.dims.y) * value_size(header_.type);
        per_piece_ =
            plane_ * uint64_t(header_.dims.z) / pieces_.size();  // checked to divide evenly
        raw_start_.resize(pieces_.size());
    }

    const Volume& header() const override { return header_; }

    /// Inflates the first plane of the first compressed piece (all of the
    /// piece when it holds less), through the discard buffer: a garbage, cut or
    /// missing stream is an error now, before a caller plans buffers from the
    /// header's dims, and a plane's worth of buffer is only ever planned for a
    /// stream shown to produce a plane. The stream is kept: a read of plane 0
    /// starts it again (that plane is inflated twice), a read further on goes
    /// on from here.
    void check_first_plane() {
        if (!compressed_ || per_piece_ == 0) return;
        stream_.emplace(pieces_[0], what_);
        open_ = 0;
        stream_->next(nullptr, std::min(plane_, per_piece_), per_piece_);
    }

    void read(int64_t z0, int64_t count, std::byte* dst) override {
        const Dims d = header_.dims;
        if (z0 < 0 || count < 0 || count > d.z || z0 > d.z - count)
            throw Error(ErrorCode::InvalidArgument, what_ + ": planes " + std::to_string(z0) +
                                                        ".." + std::to_string(z0 + count - 1) +
                                                        " outside the volume");
        if (count == 0) return;
        if (count == 1 && z0 == last_z_) {
            std::memcpy(dst, last_.data(), std::size_t(plane_));
            return;
        }
        const uint64_t begin = uint64_t(z0) * plane_, end = uint64_t(z0 + count) * plane_;
        for (uint64_t at = begin; at < end;) {
            const std::size_t i = std::size_t(at / per_piece_);
            const uint64_t off = at - uint64_t(i) * per_piece_;
            const uint64_t n = std::min(end - at, per_piece_ - off);
            if (compressed_)
                inflate_from(i, off, dst + (at - begin), n);
            else
                read_raw(i, off, dst + (at - begin), n);
            at += n;
        }
        if (swap_) swap_bytes(dst, std::size_t(end - begin), value_size(header_.type));
        if (compressed_) {
            last_.assign(dst + (end - begin - plane_), dst + (end - begin));
            last_z_ = z0 + count - 1;
        }
    }

  private:
    void read_raw(std::size_t i, uint64_t off, std::byte* dst, uint64_t n) {
        const DataPiece& p = pieces_[i];
        if (open_ != i || !file_) {
            file_.reset();
            file_ = open_read(p.path, what_);
            open_ = i;
        }
        if (!raw_start_[i]) {
            const uint64_t size = file_size_of(p.path, what_);
            seek_to(file_.get(), p.file_offset, p.path);
            const uint64_t pos = skip_lines(file_.get(), p.line_skip, p.file_offset, p.path, what_);
            raw_start_[i] = raw_piece_start(pos, size, p, per_piece_, what_);
        }
        const uint64_t start = *raw_start_[i] + off;
        seek_to(file_.get(), start, p.path);
        for (uint64_t done = 0; done < n;) {
            const std::size_t k = std::size_t(std::min<uint64_t>(kIoChunk, n - done));
            if (std::fread(dst + done, 1, k, file_.get()) != k)
                throw Error(ErrorCode::Truncated, what_ + ": cannot read data file '" + p.path +
                                                      "' (ended or failed at byte " +
                                                      std::to_string(start + done) + ")");
            done += k;
        }
    }

    void inflate_from(std::size_t i, uint64_t off, std::byte* dst, uint64_t n) {
        // Bytes already passed: this piece's stream starts again from its beginning.
        if (!stream_ || open_ != i || off < stream_->position()) {
            stream_.reset();
            stream_.emplace(pieces_[i], what_);
            open_ = i;
        }
        stream_->next(nullptr, off - stream_->position(), per_piece_);
        stream_->next(dst, n, per_piece_);
        if (stream_->position() == per_piece_) stream_->finish();
    }

    Volume header_;
    std::vector<DataPiece> pieces_;
    bool compressed_, swap_;
    std::string what_;
    uint64_t plane_ = 0, per_piece_ = 0;
    std::size_t open_ = 0;                            // the piece of file_ or stream_
    FilePtr file_;                                    // raw: the open data file
    std::vector<std::optional<uint64_t>> raw_start_;  // raw: where each piece's samples start
    std::optional<Inflater> stream_;                  // compressed: the current piece's stream
    std::vector<std::byte> last_;                     // compressed: the last plane read
    int64_t last_z_ = -1;
};

}  // namespace

std::unique_ptr<VolumePlanes> open_piece_planes(Volume header, std::vector<DataPiece> pieces,
                                                Compression compression, Endian file_endian,
                                                std::string what) {
    auto planes = std::make_unique<PiecePlanes>(std::move(header), std::move(pieces), compression,
                                                file_endian, std::move(what));
    planes->check_first_plane();
    return planes;
}

}  // namespace tetlod::detail
