// The .tlod container as a user makes and reads it: write_container to a file,
// decode_container back (both public API calls, file I/O included).
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "peer.hpp"
#include "tetlod/container.hpp"

namespace tetlod::bench {

namespace {

double largest_deviation(const Volume& a, const Volume& b) {
    double worst = 0;
    dispatch_value_type(a.type, [&](auto tag) {
        using T = decltype(tag);
        for (int64_t i = 0; i < a.count(); ++i)
            worst = std::max(worst, std::fabs(double(a.as<T>()[i]) - double(b.as<T>()[i])));
    });
    return worst;
}

TlodResult run(const Volume& v, const std::string& tmp_dir, double min_seconds, double max_error,
               bool fast_decode = false) {
    TlodResult r;
    r.available = true;
    const std::string path = (std::filesystem::path(tmp_dir) / "bench_peer.tlod").string();
    ContainerWriteOptions o;
    o.max_error = max_error;
    o.fast_decode = fast_decode;
    o.created = 0;  // no clock read: the same bytes every run
    const double enc = seconds_per_call(
        [&] {
            std::filesystem::remove(path);
            write_container(v, path, o);
        },
        min_seconds);
    r.bytes = std::filesystem::file_size(path);
    const ContainerInfo info = inspect_container(path).take();
    for (const auto& c : info.coders) {
        if (c.type == tlod::kSectionHtField) r.field_bytes += c.stored_bytes;
        else if (c.type == tlod::kSectionHtErrors) r.error_bytes += c.stored_bytes;
    }
    r.table_bytes = (info.sections.empty() ? r.bytes : info.sections.front().offset) - tlod::kHeaderSize;
    r.full_table_bytes = uint64_t{tlod::kTableEntrySize} * info.sections.size();
    for (const auto& s : info.sections) r.nonempty_sections += s.stored_size > 0;
    r.other_bytes = r.bytes - r.field_bytes - r.error_bytes;
    Volume back;
    const double dec = seconds_per_call([&] { back = decode_container(path).take(); }, min_seconds);
    r.exact = back.type == v.type && back.data == v.data;
    if (back.type == v.type && back.dims == v.dims) r.max_error = largest_deviation(v, back);
    r.encode_mbs = double(v.data.size()) / enc / 1e6;
    r.decode_mbs = double(v.data.size()) / dec / 1e6;
    std::filesystem::remove(path);
    return r;
}

}  // namespace

TlodResult run_tlod(const Volume& v, const std::string& tmp_dir, double min_seconds) {
    return run(v, tmp_dir, min_seconds, 0);
}

TlodResult run_tlod_lossy(const Volume& v, double max_error, const std::string& tmp_dir, double min_seconds) {
    return run(v, tmp_dir, min_seconds, max_error);
}

TlodResult run_tlod_fast(const Volume& v, const std::string& tmp_dir, double min_seconds) {
    return run(v, tmp_dir, min_seconds, 0, true);
}

}  // namespace tetlod::bench
