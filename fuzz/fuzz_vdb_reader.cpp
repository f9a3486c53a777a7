// libFuzzer target: the OpenVDB volume reader on arbitrary file contents (own
// header/descriptor/metadata parser, then OpenVDB in an isolated child, dense
// extent bounded by the file size). Every input must end in a volume or a
// tetlod::Error.
#include "fuzz_file_input.hpp"
#include "fuzz_read_planes.hpp"
#include "tetlod/converters/vdb.hpp"
#include "tetlod/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = tetlod::fuzz::write_input(data, size, ".vdb");
    try {
        (void)tetlod::read_vdb(path, tetlod::fuzz::read_options());
    } catch (const tetlod::Error&) {
    }
    try {  // the same file plane by plane (a persistent child answering requests)
        tetlod::fuzz::read_every_plane(tetlod::open_vdb_planes(path, tetlod::fuzz::read_options()));
    } catch (const tetlod::Error&) {
    }
    return 0;
}
