// tetlod sample: writes one of the built-in analytic volumes as a raw file, so
// every other command can be tried without data.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <ostream>

#include "cli_common.hpp"
#include "command.hpp"

namespace tetlod::cli {

namespace {

struct SampleArgs {
    std::string name, output, dims, dtype = "u8";
    int64_t size = 65;
};

std::string names_text() {
    std::string r;
    for (const auto& n : sample_volume_names()) r += (r.empty() ? "" : ", ") + n;
    return r;
}

int run_sample(const SampleArgs& a) {
    const Dims dims = a.dims.empty() ? Dims{a.size, a.size, a.size} : parse_dims(a.dims, "--dims");
    const ValueType type = parse_dtype(a.dtype, "--dtype");
    const Volume v = make_sample_volume(a.name, dims, type);
    write_raw_volume(v, a.output, Endian::Little);

    const auto range = v.range();
    auto& o = out();
    o << "wrote " << a.output << ": " << a.name << " " << format_dims(dims) << " "
      << value_type_name(type) << ", " << format_bytes(v.bytes()) << ", values "
      << format_number(range[0]) << ".." << format_number(range[1]) << "\n";
    // The geometry is not in a raw file: print the flags that restore it.
    o << "read it back with: --dims " << format_dims(dims, ',') << " --dtype "
      << value_type_name(type) << " --spacing " << format_number(v.spacing[0]) << ','
      << format_number(v.spacing[1]) << ',' << format_number(v.spacing[2]) << " --origin "
      << format_number(v.origin[0]) << ',' << format_number(v.origin[1]) << ','
      << format_number(v.origin[2]) << "\n";
    return 0;
}

const CommandRegistration sample_registration{
    Command{"sample", "Write a built-in analytic volume as a raw file", 10,
            [](CLI::App& sub) -> std::function<int()> {
                auto args = std::make_shared<SampleArgs>();
                sub.add_option("name", args->name, "Volume: " + names_text())
                    ->required()
                    ->check(CLI::IsMember(sample_volume_names()));
                sub.add_option("output", args->output, "Output raw file (little-endian, x fastest)")
                    ->required();
                auto* size = sub.add_option("--size", args->size, "Samples along each axis")
                                 ->capture_default_str()
                                 ->check(CLI::Range(int64_t{2}, kMaxAxisSize));
                sub.add_option("--dims", args->dims, "Samples per axis X,Y,Z (instead of --size)")
                    ->excludes(size)
                    ->check(check_with([](const std::string& s) { parse_dims(s, ""); }));
                sub.add_option("--dtype", args->dtype,
                               "Sample type: u8|i8|u16|i16|u32|i32|f32|f64 "
                               "(integers span the type's full range)")
                    ->capture_default_str()
                    ->check(check_with([](const std::string& s) { parse_dtype(s, ""); }));
                sub.footer(
                    "Examples:\n"
                    "  tetlod sample marschner-lobb ml_65x65x65_uint8.raw\n"
                    "  tetlod sample multiscale ms.raw --dims 129,129,65 --dtype f32\n");
                return [args] { return run_sample(*args); };
            }}};

}  // namespace

}  // namespace tetlod::cli
