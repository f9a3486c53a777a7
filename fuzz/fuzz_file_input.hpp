#pragma once
// The HDF5 and VDB readers take a path, not bytes: each fuzz input is written to
// a per-process temporary file first. TETLOD_FUZZ_NO_ISOLATION=1 reads in the
// fuzzing process itself: libFuzzer then sees coverage inside the library's
// calls and our code after them, and a library crash stops the run (use it to
// find validation gaps; with isolation, library crashes are the expected clean
// errors and only the guards and the parent side are covered).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "tetlod/converters/volume_read_options.hpp"

namespace tetlod::fuzz {

inline std::string write_input(const uint8_t* data, size_t size, const char* extension) {
    static const std::string path = [&] {
        const char* dir = std::getenv("TMPDIR");
        return std::string(dir && *dir ? dir : "/tmp") + "/tetlod_fuzz_" + std::to_string(::getpid()) + extension;
    }();
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();
    if (size > 0) std::fwrite(data, 1, size, f);
    std::fclose(f);
    return path;
}

inline VolumeReadOptions read_options() {
    VolumeReadOptions o;
    o.isolation.enabled = std::getenv("TETLOD_FUZZ_NO_ISOLATION") == nullptr;
    o.isolation.timeout_seconds = 5;
    return o;
}

}  // namespace tetlod::fuzz
