#include "model_choice.hpp"

namespace tetlod::cli {

ModelKind parse_model_kind(const std::string& text) {
    if (const auto k = tetlod::parse_model_kind(text)) return *k;
    throw Error(ErrorCode::InvalidArgument, "--model '" + text + "': expected ht or mt");
}

ModelKind resolve_model(const std::string& given, const std::string& input) {
    std::optional<ModelKind> requested;
    if (!given.empty()) requested = parse_model_kind(given);
    try {
        return choose_model(input, requested);
    } catch (const Error& e) {
        const char* other = *requested == ModelKind::Ht ? "mt" : "ht";
        throw Error(e.code(), "--model " + given + ": " + e.what() + "; drop --model or use --model " + other);
    }
}

LodModel load_model(const std::string& path, ModelKind kind, const VolumeFlags& flags, bool pad,
                    bool measure_storage) {
    ModelBuildOptions o;
    o.pad = pad;
    o.measure_storage = measure_storage;
    return open_model(path, kind, flags.options(), o).take();
}

}  // namespace tetlod::cli
