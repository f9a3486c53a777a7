#include "tetlod/core/isolated_volume.hpp"

#include <algorithm>
#include <cstring>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

constexpr char kMagic[4] = {'T', 'L', 'V', 'X'};
// Bounds on what a (possibly corrupted) child may claim before the parent allocates.
constexpr uint64_t kMaxStringBytes = uint64_t{1} << 24;
constexpr uint64_t kMaxEntries = uint64_t{1} << 20;
constexpr std::size_t kBlockBytes = std::size_t{1} << 24;

template <class T>
void put(IsolatedWriter& w, const T& v) {
    w.write(&v, sizeof v);
}
void put_string(IsolatedWriter& w, const std::string& s) {
    put<uint64_t>(w, s.size());
    w.write(s.data(), s.size());
}

template <class T>
T get(IsolatedReader& r) {
    T v;
    r.read(&v, sizeof v);
    return v;
}

Error bad_result(const IsolatedTask& task, const std::string& why) {
    return Error(ErrorCode::CorruptData,
                 task.library + " sent an invalid result for '" + task.file + "' (" + why + "): the file is corrupt");
}

std::string get_string(IsolatedReader& r, const IsolatedTask& task) {
    const uint64_t n = get<uint64_t>(r);
    if (n > kMaxStringBytes) throw bad_result(task, "string of " + std::to_string(n) + " bytes");
    std::string s(static_cast<std::size_t>(n), '\0');
    r.read(s.data(), s.size());
    return s;
}

}  // namespace

void send_volume_header(IsolatedWriter& w, const Volume& v) {
    w.write(kMagic, sizeof kMagic);
    put<uint32_t>(w, static_cast<uint32_t>(v.type));
    put<int64_t>(w, v.dims.x);
    put<int64_t>(w, v.dims.y);
    put<int64_t>(w, v.dims.z);
    for (double s : v.spacing) put<double>(w, s);
    for (double o : v.origin) put<double>(w, o);
    put_string(w, v.field_name);
    put_string(w, v.units);
    put<uint64_t>(w, v.metadata.size());
    for (const auto& [k, val] : v.metadata) {
        put_string(w, k);
        put_string(w, val);
    }
}

Volume receive_volume_header(IsolatedReader& r, const IsolatedTask& task) {
    Volume out;
    char magic[4];
    r.read(magic, sizeof magic);
    if (std::memcmp(magic, kMagic, sizeof magic) != 0) throw bad_result(task, "bad frame");
    const uint32_t type = get<uint32_t>(r);
    if (type < static_cast<uint32_t>(ValueType::U8) || type > static_cast<uint32_t>(ValueType::F64))
        throw bad_result(task, "value type");
    out.type = static_cast<ValueType>(type);
    out.dims.x = get<int64_t>(r);
    out.dims.y = get<int64_t>(r);
    out.dims.z = get<int64_t>(r);
    try {
        validate_dims(out.dims, "'" + task.file + "'");
    } catch (const Error& e) {
        throw bad_result(task, e.what());
    }
    for (double& s : out.spacing) s = get<double>(r);
    for (double& o : out.origin) o = get<double>(r);
    out.field_name = get_string(r, task);
    out.units = get_string(r, task);
    const uint64_t entries = get<uint64_t>(r);
    if (entries > kMaxEntries) throw bad_result(task, std::to_string(entries) + " metadata entries");
    for (uint64_t i = 0; i < entries; ++i) {
        std::string k = get_string(r, task);
        out.metadata[std::move(k)] = get_string(r, task);
    }
    return out;
}

Volume read_volume_isolated(const IsolatedTask& task, const std::function<Volume()>& read) {
    Volume out;
    run_isolated(
        task,
        [&](IsolatedWriter& w) {
            Volume v = read();
            send_volume_header(w, v);
            put<uint64_t>(w, v.data.size());
            w.write(v.data.data(), v.data.size());
        },
        [&](IsolatedReader& r) {
            out = receive_volume_header(r, task);
            const uint64_t bytes = get<uint64_t>(r);
            if (bytes != static_cast<uint64_t>(out.dims.count()) * value_size(out.type))
                throw bad_result(task, "sample bytes do not match the dims");
            // Grow as bytes arrive: memory follows what was sent, not what was claimed.
            out.data.clear();
            while (out.data.size() < bytes) {
                const std::size_t at = out.data.size();
                const std::size_t n = static_cast<std::size_t>(std::min<uint64_t>(kBlockBytes, bytes - at));
                out.data.resize(at + n);
                r.read(out.data.data() + at, n);
            }
        });
    return out;
}

std::vector<std::pair<std::string, std::string>> read_pairs_isolated(
    const IsolatedTask& task, const std::function<std::vector<std::pair<std::string, std::string>>()>& read) {
    std::vector<std::pair<std::string, std::string>> out;
    run_isolated(
        task,
        [&](IsolatedWriter& w) {
            auto pairs = read();
            put<uint64_t>(w, pairs.size());
            for (const auto& [a, b] : pairs) {
                put_string(w, a);
                put_string(w, b);
            }
        },
        [&](IsolatedReader& r) {
            const uint64_t n = get<uint64_t>(r);
            if (n > kMaxEntries) throw bad_result(task, std::to_string(n) + " entries");
            for (uint64_t i = 0; i < n; ++i) {
                std::string a = get_string(r, task);
                out.emplace_back(std::move(a), get_string(r, task));
            }
        });
    return out;
}

}  // namespace tetlod
