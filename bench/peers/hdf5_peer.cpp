// HDF5 gzip-9 + shuffle: the library's own HDF5 writer (z-slab chunks, the
// shuffle filter, deflate), so the bench stays out of hdf5.h like every file
// but the HDF5 converter's. Read back in this process (no isolation child: the
// file is ours and the child would dominate the time).
#include <filesystem>

#include "peer.hpp"

#if TETLOD_BENCH_HAVE_HDF5
#include "tetlod/converters/hdf5.hpp"
#endif

namespace tetlod::bench {

PeerResult run_hdf5_gzip(const Volume& v, int level, const std::string& tmp_dir, double min_seconds) {
    PeerResult r;
#if TETLOD_BENCH_HAVE_HDF5
    r.available = true;
    const std::string path = (std::filesystem::path(tmp_dir) / "bench_peer.h5").string();
    Hdf5WriteOptions wo;
    wo.deflate_level = level;
    const double enc = seconds_per_call(
        [&] {
            std::filesystem::remove(path);
            write_hdf5(v, path, "volume", wo);
        },
        min_seconds);
    r.bytes = std::filesystem::file_size(path);
    VolumeReadOptions ro;
    ro.isolation.enabled = false;
    Volume back;
    const double dec = seconds_per_call([&] { back = read_hdf5(path, "volume", ro); }, min_seconds);
    r.exact = back.type == v.type && back.data == v.data;
    r.encode_mbs = double(v.data.size()) / enc / 1e6;
    r.decode_mbs = double(v.data.size()) / dec / 1e6;
    std::filesystem::remove(path);
#else
    (void)v, (void)level, (void)tmp_dir, (void)min_seconds;
    r.why = "built without HDF5";
#endif
    return r;
}

}  // namespace tetlod::bench
