// Replays files (or every file of directories) through LLVMFuzzerTestOneInput,
// so the fuzz corpus runs as a ctest with the normal compiler.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
    int n = 0;
    for (int i = 1; i < argc; ++i) {
        std::vector<std::filesystem::path> files;
        if (std::filesystem::is_directory(argv[i])) {
            for (auto& e : std::filesystem::recursive_directory_iterator(argv[i]))
                if (e.is_regular_file()) files.push_back(e.path());
        } else {
            files.push_back(argv[i]);
        }
        for (const auto& f : files) {
            std::ifstream in(f, std::ios::binary);
            std::vector<char> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
            // Every prefix too: the reader must fail cleanly on each.
            for (std::size_t len = 0; len <= b.size(); len += (len < 256 ? 1 : 97))
                LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(b.data()), len);
            LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(b.data()), b.size());
            ++n;
        }
    }
    std::printf("replayed %d corpus files\n", n);
    return n > 0 ? 0 : 1;
}
