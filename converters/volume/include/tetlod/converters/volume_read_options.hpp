#pragma once
// Options a user can give when a volume is read. Each reader uses the ones that
// apply to its format and ignores the rest; raw volumes need dims and type
// unless the file name follows NAME_XxYxZ_DTYPE.raw.
#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "tetlod/core/isolated_process.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

enum class Endian { Little, Big };

struct VolumeReadOptions {
    // raw
    std::optional<Dims> dims;
    std::optional<ValueType> type;
    Endian endian = Endian::Little;
    uint64_t header_bytes = 0;
    // any format: override what the file says
    std::optional<Vec3> spacing;
    std::optional<Vec3> origin;
    // OpenVDB: grid name (default: the only scalar grid)
    std::string grid;
    // HDF5: "zyx" (C order [z][y][x], default) or "xyz"
    std::string axis_order;
    // NRRD/MetaImage: read data files the header names outside its own folder
    // (absolute paths elsewhere, ".."). Off by default: a header downloaded with
    // a dataset must not make tetlod read arbitrary files such as /etc/shadow.
    bool allow_external_data = false;
    // OpenVDB and HDF5: the third-party library reads in a child process with a
    // time limit, so a crash or hang inside it becomes a clean error (default on).
    IsolationOptions isolation;
};

}  // namespace tetlod
