// Version constants, checksums and the zstd frame helpers of the container.
#include <xxhash.h>
#include <zstd.h>

#include <cstdio>
#include <memory>

#include "tetlod/core/regular_file.hpp"
#include "tetlod/format/container.hpp"

namespace tetlod::tlod {

// The spec version this library implements (spec/tlod-format.md §3): its newest
// writer feature is chunk mode 7, range-exp (3.8).
const char* format_version_string() { return "tlod-format 3.8"; }

uint64_t checksum64(std::span<const std::byte> bytes) {
    return XXH64(bytes.data(), bytes.size(), 0);
}

Expected<uint64_t> checksum64_file(const std::string& path) {
    if (auto bad = regular_file_failure(path, "container")) return *bad;
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return fail(ErrorCode::IoError, "cannot open '" + path + "'");
    XXH64_state_t* st = XXH64_createState();
    XXH64_reset(st, 0);
    std::vector<char> buf(1 << 20);
    std::size_t n;
    while ((n = std::fread(buf.data(), 1, buf.size(), f)) > 0) XXH64_update(st, buf.data(), n);
    const bool bad = std::ferror(f) != 0;
    std::fclose(f);
    const uint64_t h = XXH64_digest(st);
    XXH64_freeState(st);
    if (bad) return fail(ErrorCode::IoError, "cannot read '" + path + "'");
    return h;
}

namespace {

struct CCtxFree {
    void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
using CCtxPtr = std::unique_ptr<ZSTD_CCtx, CCtxFree>;

/// Inputs up to this size reuse one compression context per thread. The HT
/// encoder compresses thousands of chunk-sized inputs (tens of KiB, twice
/// each when the samples mode is tried); a fresh context allocated, faulted
/// in and cleared its match tables for every one of them. Larger inputs
/// (whole sections of the MT or metadata) take a fresh context as before, so
/// a thread never keeps the tables of a large input (tens of MiB at level 19).
constexpr std::size_t kReusedContextMaxInput = std::size_t{1} << 20;

/// A context with every parameter at its default: a reused one is reset, so
/// its frames are the same bytes as a fresh context's (zstd's output depends
/// on the parameters and the input only).
ZSTD_CCtx* compression_context(std::size_t input_size, CCtxPtr& fresh) {
    if (input_size > kReusedContextMaxInput) {
        fresh.reset(ZSTD_createCCtx());
        return fresh.get();
    }
    thread_local CCtxPtr reused;
    if (!reused) reused.reset(ZSTD_createCCtx());
    if (reused) ZSTD_CCtx_reset(reused.get(), ZSTD_reset_session_and_parameters);
    return reused.get();
}

}  // namespace

std::vector<std::byte> zstd_compress(std::span<const std::byte> raw, int level) {
    std::vector<std::byte> out(ZSTD_compressBound(raw.size()));
    CCtxPtr fresh;
    ZSTD_CCtx* cctx = compression_context(raw.size(), fresh);
    if (!cctx) throw Error(ErrorCode::IoError, "zstd: out of memory");
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, level);
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 1);
    // Our own XXH64 covers the stored bytes; zstd's checksum would be redundant.
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 0);
    std::size_t n = ZSTD_compress2(cctx, out.data(), out.size(), raw.data(), raw.size());
    if (ZSTD_isError(n))
        throw Error(ErrorCode::IoError, std::string("zstd compression failed: ") +
                                            ZSTD_getErrorName(n));
    out.resize(n);
    return out;
}

Expected<std::vector<std::byte>> zstd_decompress(std::span<const std::byte> stored,
                                                 uint64_t raw_size) {
    // The frame must be exactly one frame filling the stored bytes.
    std::size_t frame = ZSTD_findFrameCompressedSize(stored.data(), stored.size());
    if (ZSTD_isError(frame))
        return fail(ErrorCode::CorruptData,
                    std::string("bad zstd frame: ") + ZSTD_getErrorName(frame));
    if (frame != stored.size())
        return fail(ErrorCode::CorruptData, "bytes after the zstd frame in a section");
    unsigned long long declared = ZSTD_getFrameContentSize(stored.data(), stored.size());
    if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN)
        return fail(ErrorCode::CorruptData, "zstd frame without a content size");
    if (declared != raw_size)
        return fail(ErrorCode::CorruptData, "zstd frame content size " + std::to_string(declared) +
                                                " differs from the section's raw size " +
                                                std::to_string(raw_size));
    // A zstd block expands to at most 128 KiB and takes at least 4 bytes (RLE):
    // a larger claim cannot be honest and is refused before allocating.
    if (raw_size > uint64_t(stored.size()) * 32768 + 131072)
        return fail(ErrorCode::CorruptData, "zstd frame of " + std::to_string(stored.size()) +
                                                " bytes cannot expand to the claimed " + std::to_string(raw_size));
    // Streamed into a buffer that grows with the output, so a frame whose blocks
    // are garbage fails before its claimed size is allocated.
    std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> dctx(ZSTD_createDCtx(), &ZSTD_freeDCtx);
    if (!dctx) return fail(ErrorCode::TooLarge, "zstd: out of memory");
    std::vector<std::byte> out;
    ZSTD_inBuffer in{stored.data(), stored.size(), 0};
    uint64_t done = 0;
    constexpr uint64_t kStep = uint64_t{1} << 20;
    for (;;) {
        const uint64_t want = std::min<uint64_t>(raw_size, std::max<uint64_t>(done + kStep, 2 * done));
        try {
            if (want > out.size()) out.resize(static_cast<std::size_t>(want));
        } catch (const std::bad_alloc&) {
            return fail(ErrorCode::TooLarge, "cannot allocate " + std::to_string(want) + " bytes");
        }
        ZSTD_outBuffer ob{out.data(), out.size(), static_cast<std::size_t>(done)};
        const std::size_t in_before = in.pos;
        const std::size_t rc = ZSTD_decompressStream(dctx.get(), &ob, &in);
        if (ZSTD_isError(rc))
            return fail(ErrorCode::CorruptData, std::string("zstd decompression failed: ") + ZSTD_getErrorName(rc));
        const bool progress = ob.pos != done || in.pos != in_before;
        done = ob.pos;
        if (rc == 0) break;  // frame complete
        if (!progress && (in.pos == in.size || done == raw_size))
            return fail(ErrorCode::CorruptData, "zstd frame ends early or expands past its content size");
    }
    if (done != raw_size || in.pos != in.size)
        return fail(ErrorCode::CorruptData, "zstd frame expanded to the wrong size");
    out.resize(static_cast<std::size_t>(done));
    return out;
}

}  // namespace tetlod::tlod
