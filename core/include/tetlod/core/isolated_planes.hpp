#pragma once
// A volume read plane by plane by a third-party library in an isolated child
// (IsolatedServer): the child opens the file once and keeps it open; each
// read() of the parent is a request (z0, count) answered with those planes.
// The parent allocates nothing from the child's claims: it checks the header
// the child sends (valid dims, bounded strings) and reads each answer straight
// into the caller's buffer, whose size it knows from that header.
#include <cstdint>
#include <functional>
#include <memory>

#include "tetlod/core/isolated_process.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

/// What the child opened: an in-process reader of the planes, and the memory
/// its reads need beyond the child's request buffer (library caches, scratch).
struct PlanesInChild {
    std::unique_ptr<VolumePlanes> planes;
    uint64_t working_bytes = 0;
};

/// Largest answer the child holds at once: a read is answered in pieces of at
/// most this many bytes (one plane when a plane is larger).
inline constexpr uint64_t kIsolatedPieceBytes = uint64_t{16} << 20;

/// Runs `open` in a child under `task`'s time and memory limits (the opening
/// phase: headers, metadata) and returns planes read through it. Once opened
/// (and its answer buffer of one piece allocated), the child's further memory
/// is capped at options.memory_limit_bytes when set, else
/// options.memory_base_bytes + working_bytes: reading costs what a request
/// needs, not what the file is. Each read
/// must finish within isolation_time_limit(options, bytes read). Errors as
/// IsolatedServer's (tetlod::Error naming task.file); the child is killed and
/// reaped when the result is destroyed.
std::unique_ptr<VolumePlanes> open_planes_isolated(const IsolatedTask& task,
                                                   const IsolationOptions& options,
                                                   const std::function<PlanesInChild()>& open);

}  // namespace tetlod
