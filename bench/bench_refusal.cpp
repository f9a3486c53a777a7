// Peak memory of refusing a hostile container, against decoding the same
// container intact (peer, same run). The hostile file is a correctly
// checksummed HT container of a constant N^3 volume (a few KB that legitimately
// claim N^3 points) whose first non-empty field chunk is replaced by garbage:
// the decoder must fail there having committed only what it decoded, not the
// N^3 field and errors the header announces.
//
//   build/bench/bench_refusal [--sizes 257,513]
//
// Each decode runs in a fresh process (this program re-executed with --decode)
// so its peak RSS (wait4) is its own.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tetlod/codecs/ht/ht_codec.hpp"
#include "tetlod/format/byte_io.hpp"
#include "tetlod/format/container.hpp"
#include "tetlod/format/metadata.hpp"

using namespace tetlod;

namespace {

std::vector<std::byte> constant_container(int n) {
    Volume v = Volume::allocate({n, n, n}, ValueType::U8);
    std::memset(v.data.data(), 77, v.data.size());
    HtModel m = HtModel::build(v);
    tlod::ContainerWriter w;
    encode_ht(m, tlod::metadata_for_volume(v), w);
    return w.finish();
}

/// Garbage in the first non-empty field section; checksums recomputed so the
/// file passes every framing check and reaches the chunk decoder.
std::vector<std::byte> with_garbage_chunk(std::vector<std::byte> f) {
    const uint32_t count = uint32_t(tlod::load_le(f.data() + 40, 4));
    for (uint32_t i = 0; i < count; ++i) {
        std::byte* e = f.data() + 64 + 48 * i;
        const uint64_t off = tlod::load_le(e + 8, 8), size = tlod::load_le(e + 16, 8);
        if (tlod::load_le(e, 4) != tlod::kSectionHtField || size == 0) continue;
        for (uint64_t b = 0; b < size; ++b) f[off + b] = std::byte(uint8_t(0xA5 ^ (b * 131)));
        tlod::store_le(e + 40, tlod::checksum64(std::span<const std::byte>(f.data() + off, size)), 8);
        tlod::store_le(f.data() + 48, tlod::checksum64(std::span<const std::byte>(f.data() + 64, count * 48)), 8);
        tlod::store_le(f.data() + 56, tlod::checksum64(std::span<const std::byte>(f.data(), 56)), 8);
        return f;
    }
    return f;
}

int decode_child(const char* path) {
    auto r = tlod::ContainerReader::open(path);
    if (!r) {
        std::printf("%s\n", r.failure().message.c_str());
        return 2;
    }
    auto d = decode_ht(*r);
    if (!d) {
        std::printf("%s\n", d.failure().message.c_str());
        return 1;
    }
    return 0;
}

struct Run {
    int status = -1;
    double peak_mb = 0;
};

Run run_decode(const std::string& path) {
    Run out;
    const pid_t pid = fork();
    if (pid == 0) {
        execl("/proc/self/exe", "bench_refusal", "--decode", path.c_str(), static_cast<char*>(nullptr));
        _exit(127);
    }
    int st = 0;
    rusage ru{};
    wait4(pid, &st, 0, &ru);
    out.status = WIFEXITED(st) ? WEXITSTATUS(st) : -WTERMSIG(st);
    out.peak_mb = double(ru.ru_maxrss) / 1024.0;
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc == 3 && std::strcmp(argv[1], "--decode") == 0) return decode_child(argv[2]);
    std::vector<int> sizes{257, 513};
    if (argc == 3 && std::strcmp(argv[1], "--sizes") == 0) {
        sizes.clear();
        std::stringstream ss(argv[2]);
        for (std::string t; std::getline(ss, t, ',');) sizes.push_back(std::stoi(t));
    }
    std::printf("%-7s %12s %14s %16s %18s %14s\n", "volume", "file bytes", "claimed MB",
                "intact decode MB", "garbage chunk MB", "refused");
    for (int n : sizes) {
        const std::string good = "bench_refusal_" + std::to_string(n) + ".tlod";
        const std::string bad = "bench_refusal_" + std::to_string(n) + "_bad.tlod";
        uint64_t bytes = 0;
        {
            auto f = constant_container(n);
            bytes = f.size();
            std::ofstream(good, std::ios::binary).write(reinterpret_cast<const char*>(f.data()), std::streamsize(f.size()));
            auto g = with_garbage_chunk(std::move(f));
            std::ofstream(bad, std::ios::binary).write(reinterpret_cast<const char*>(g.data()), std::streamsize(g.size()));
        }
        // Field (1 B/point) + errors (4 B/point) the header announces.
        const double claimed = double(n) * n * n * 5 / (1024.0 * 1024.0);
        const Run intact = run_decode(good), hostile = run_decode(bad);
        std::printf("%-7s %12llu %14.0f %16.1f %18.1f %14s\n", (std::to_string(n) + "^3").c_str(),
                    static_cast<unsigned long long>(bytes), claimed, intact.peak_mb, hostile.peak_mb,
                    hostile.status == 1 && intact.status == 0 ? "yes" : "NO");
        std::remove(good.c_str());
        std::remove(bad.c_str());
    }
}
