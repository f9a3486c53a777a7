// zstd -19 --long=27 of the raw samples, through libzstd's advanced API (the
// command line's --long sets exactly these two parameters).
#include <zstd.h>

#include <cstring>
#include <vector>

#include "peer.hpp"

namespace tetlod::bench {

PeerResult run_zstd(const Volume& v, int level, int window_log, double min_seconds) {
    PeerResult r;
    r.available = true;
    ZSTD_CCtx* c = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(c, ZSTD_c_compressionLevel, level);
    ZSTD_CCtx_setParameter(c, ZSTD_c_windowLog, window_log);
    ZSTD_CCtx_setParameter(c, ZSTD_c_enableLongDistanceMatching, 1);
    std::vector<char> z(ZSTD_compressBound(v.data.size()));
    std::size_t zn = 0;
    const double enc = seconds_per_call([&] { zn = ZSTD_compress2(c, z.data(), z.size(), v.data.data(), v.data.size()); },
                                        min_seconds);
    ZSTD_freeCCtx(c);
    if (ZSTD_isError(zn)) {
        r.available = false;
        r.why = ZSTD_getErrorName(zn);
        return r;
    }
    ZSTD_DCtx* d = ZSTD_createDCtx();
    ZSTD_DCtx_setParameter(d, ZSTD_d_windowLogMax, window_log);
    std::vector<std::byte> back(v.data.size());
    std::size_t bn = 0;
    const double dec = seconds_per_call([&] { bn = ZSTD_decompressDCtx(d, back.data(), back.size(), z.data(), zn); },
                                        min_seconds);
    ZSTD_freeDCtx(d);
    r.bytes = zn;
    r.exact = bn == v.data.size() && std::memcmp(back.data(), v.data.data(), bn) == 0;
    r.encode_mbs = double(v.data.size()) / enc / 1e6;
    r.decode_mbs = double(v.data.size()) / dec / 1e6;
    return r;
}

}  // namespace tetlod::bench
