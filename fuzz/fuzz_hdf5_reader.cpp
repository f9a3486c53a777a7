// libFuzzer target: the HDF5 volume reader on arbitrary file contents (own
// superblock check, then libhdf5 in an isolated child, claims checked before
// allocating). Every input must end in a volume or a tetlod::Error.
#include "fuzz_file_input.hpp"
#include "fuzz_read_planes.hpp"
#include "tetlod/converters/hdf5.hpp"
#include "tetlod/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = tetlod::fuzz::write_input(data, size, ".h5");
    try {
        (void)tetlod::read_hdf5(path, "", tetlod::fuzz::read_options());
    } catch (const tetlod::Error&) {
    }
    try {  // the same file plane by plane (a persistent child answering requests)
        tetlod::fuzz::read_every_plane(tetlod::open_hdf5_planes(path, "", tetlod::fuzz::read_options()));
    } catch (const tetlod::Error&) {
    }
    return 0;
}
