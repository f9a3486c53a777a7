#pragma once
// --model as the commands take it: which model of an input to use, with the
// command line's messages when the input cannot provide it.
#include <string>

#include "cli_common.hpp"

namespace tetlod::cli {

/// "ht"/"HT" or "mt"/"MT"; anything else is InvalidArgument naming --model.
ModelKind parse_model_kind(const std::string& text);

/// --model as given; when not given (empty), the only model of a container that
/// holds just an MT is "mt", everything else "ht". Asking a container for a model
/// it lacks is InvalidArgument saying which it holds.
std::string resolve_model(const std::string& given, const std::string& input);

/// open_model with the volume flags; throws the failure.
LodModel load_model(const std::string& path, ModelKind kind, const VolumeFlags& flags, bool pad,
                    bool measure_storage);

}  // namespace tetlod::cli
