#include "model_choice.hpp"

namespace tetlod::cli {

ModelKind parse_model_kind(const std::string& text) {
    if (const auto k = tetlod::parse_model_kind(text)) return *k;
    throw Error(ErrorCode::InvalidArgument, "--model '" + text + "': expected ht or mt");
}

std::string resolve_model(const std::string& given, const std::string& input) {
    if (!is_container_path(input)) return given.empty() ? "ht" : given;
    const ContainerModels m = container_models(input);
    if (!m.ht && !m.mt) return given.empty() ? "ht" : given;  // unreadable: the reader says why
    if (given.empty()) return m.mt && !m.ht ? "mt" : "ht";   // the only model present
    if ((given == "ht" && !m.ht) || (given == "mt" && !m.mt))
        throw Error(ErrorCode::InvalidArgument,
                    "--model " + given + ": '" + input + "' holds no " + (given == "ht" ? "HT" : "MT") +
                        " (it holds the " + (m.ht ? "HT" : "MT") + "; drop --model or use --model " +
                        (m.ht ? "ht" : "mt") + ")");
    return given;
}

LodModel load_model(const std::string& path, ModelKind kind, const VolumeFlags& flags, bool pad,
                    bool measure_storage) {
    ModelBuildOptions o;
    o.pad = pad;
    o.measure_storage = measure_storage;
    return open_model(path, kind, flags.options(), o).take();
}

}  // namespace tetlod::cli
