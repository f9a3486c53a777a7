#pragma once
// --model as the commands take it: which model of an input to use, with the
// command line's messages when the input cannot provide it.
#include <string>

#include "cli_common.hpp"

namespace tetlod::cli {

/// "ht"/"HT" or "mt"/"MT"; anything else is InvalidArgument naming --model.
ModelKind parse_model_kind(const std::string& text);

/// choose_model (tetlod/model.hpp) for --model as given (empty: not given), with
/// the flag named in the message when the container lacks the model asked for.
ModelKind resolve_model(const std::string& given, const std::string& input);

/// open_model with the volume flags; throws the failure.
LodModel load_model(const std::string& path, ModelKind kind, const VolumeFlags& flags, bool pad,
                    bool measure_storage);

}  // namespace tetlod::cli
