#pragma once
// Shared body of the NRRD and MetaImage targets: the input is a header, then
// optionally "\n@@DATA@@\n" and the bytes of a data file named "d.raw" beside it
// (further "@@DATA@@" parts become d1.raw, d2.raw, ...). Files go to a private
// scratch folder; the reader runs with default options (no external data files).
#include <string>
#include <string_view>

#include "fuzz_split.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod_fuzz {

template <class Read>
void read_header_and_data(const uint8_t* data, size_t size, const char* header_name, Read read) {
    const auto parts = split(std::string_view(reinterpret_cast<const char*>(data), size), "\n@@DATA@@\n", 8);
    const std::string dir = scratch_dir();
    const std::string header = dir + "/" + header_name;
    write_file(header, parts[0]);
    for (std::size_t i = 1; i < parts.size(); ++i)
        write_file(dir + "/" + (i == 1 ? std::string("d.raw") : "d" + std::to_string(i - 1) + ".raw"), parts[i]);
    try {
        tetlod::Volume v = read(header);
        (void)v;
    } catch (const tetlod::Error&) {
    }
}

}  // namespace tetlod_fuzz
