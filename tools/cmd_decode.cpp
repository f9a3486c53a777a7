// tetlod decode: a .tlod container -> the original volume as a raw file, bit-exact.
#include <CLI/CLI.hpp>

#include <ostream>

#include "cli_common.hpp"
#include "command.hpp"
#include "tetlod/codec/ht/ht_codec.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"

namespace tetlod::cli {

namespace {

int run_decode(const std::string& input, const std::string& output) {
    Stopwatch sw;
    auto r = tlod::ContainerReader::open(input);
    if (!r) throw Error(r.failure().code, r.failure().message);
    auto v = decode_volume(*r);
    if (!v) throw Error(v.failure().code, v.failure().message);
    write_file_atomic(output, v->data.data(), v->data.size());
    out() << "wrote " << output << ": " << format_dims(v->dims) << " " << value_type_name(v->type)
          << " little-endian, x fastest, " << format_bytes(v->data.size()) << " in "
          << format_seconds(sw.seconds()) << "\n";
    out() << "read it back with: --dims " << format_dims(v->dims, ',') << " --dtype "
          << value_type_name(v->type) << " --spacing " << format_number(v->spacing[0]) << ','
          << format_number(v->spacing[1]) << ',' << format_number(v->spacing[2]) << " --origin "
          << format_number(v->origin[0]) << ',' << format_number(v->origin[1]) << ','
          << format_number(v->origin[2]) << "\n";
    return 0;
}

const CommandRegistration registration{Command{
    "decode", "Decode a .tlod container to the original raw volume (bit-exact)", 23,
    [](CLI::App& sub) -> std::function<int()> {
        auto in = std::make_shared<std::string>();
        auto outp = std::make_shared<std::string>();
        sub.add_option("input", *in, "Input .tlod file")->required();
        sub.add_option("output", *outp, "Output raw file (little-endian, x fastest)")->required();
        sub.footer("Examples:\n  tetlod decode neghip.tlod neghip_64x64x64_uint8.raw");
        return [in, outp] { return run_decode(*in, *outp); };
    }}};

}  // namespace

}  // namespace tetlod::cli
