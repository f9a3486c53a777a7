#pragma once
// A volume read in an isolated child process (run_isolated) and sent back
// through the pipe: header, strings, metadata, samples. The parent checks every
// count it receives and allocates only as the samples arrive, so even a child
// whose memory was corrupted by the library cannot make it allocate from claims.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "tetlod/core/isolated_process.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod {

/// Runs `read` in a child process and returns its volume (see run_isolated for
/// the errors).
Volume read_volume_isolated(const IsolatedTask& task, const std::function<Volume()>& read);

/// The header of a volume (all but its samples), as read_volume_isolated sends it.
void send_volume_header(IsolatedWriter& w, const Volume& v);
/// Reads what send_volume_header sent, checking it (dims valid, strings and
/// entries bounded) before allocating; CorruptData naming task.file otherwise.
Volume receive_volume_header(IsolatedReader& r, const IsolatedTask& task);

/// Same for a list of string pairs (e.g. grid names and types).
std::vector<std::pair<std::string, std::string>> read_pairs_isolated(
    const IsolatedTask& task, const std::function<std::vector<std::pair<std::string, std::string>>()>& read);

}  // namespace tetlod
