#include "hdf5_read_guard.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/regular_file.hpp"

namespace tetlod::hdf5_guard {

namespace {

constexpr unsigned char kSignature[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};

bool valid_size_field(unsigned v) { return v == 2 || v == 4 || v == 8 || v == 16 || v == 32; }

// External links are never followed: a file that names another file (possibly
// a FIFO or a device) must not make tetlod open it.
herr_t refuse_external_link(const char*, const char*, const char*, const char*, unsigned*, hid_t, void*) {
    return -1;
}

}  // namespace

void check_hdf5_superblock(const std::string& file, uint64_t file_size) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw Error(ErrorCode::IoError, "cannot open '" + file + "'");
    // The superblock sits at 0 or after a user block of 512, 1024, 2048, ... bytes.
    for (uint64_t at = 0; at + sizeof kSignature <= file_size; at = at == 0 ? 512 : at * 2) {
        std::array<unsigned char, 16> b{};
        in.clear();
        in.seekg(static_cast<std::streamoff>(at));
        in.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(b.size()));
        const auto got = static_cast<std::size_t>(in.gcount());
        if (got < sizeof kSignature || !std::equal(kSignature, kSignature + 8, b.begin())) continue;
        if (got < b.size())
            throw Error(ErrorCode::Truncated, "'" + file + "': the HDF5 superblock is truncated");
        const unsigned version = b[8];
        if (version > 3)
            throw Error(ErrorCode::UnsupportedVersion,
                        "'" + file + "': HDF5 superblock version " + std::to_string(version) + " (tetlod reads 0 to 3)");
        const unsigned offsets = version <= 1 ? b[13] : b[9];
        const unsigned lengths = version <= 1 ? b[14] : b[10];
        if (!valid_size_field(offsets) || !valid_size_field(lengths))
            throw Error(ErrorCode::CorruptData, "'" + file + "': the HDF5 superblock declares " +
                                                    std::to_string(offsets) + "-byte addresses and " +
                                                    std::to_string(lengths) + "-byte lengths: the file is corrupt");
        return;
    }
    throw Error(ErrorCode::BadMagic, "'" + file + "' is not an HDF5 file");
}

hid_t make_safe_dataset_access(const std::string& file) {
    (void)file;
    hid_t dapl = H5Pcreate(H5P_DATASET_ACCESS);
    if (dapl < 0) return H5P_DEFAULT;
    H5Pset_elink_cb(dapl, refuse_external_link, nullptr);
    H5Pset_efile_prefix(dapl, "${ORIGIN}");
    return dapl;
}

void check_dataset_claims(hid_t dataset, hid_t dcpl, uint64_t declared_bytes, uint64_t element_bytes,
                          const std::string& file, uint64_t file_size, const std::string& what) {
    const H5D_layout_t layout = H5Pget_layout(dcpl);
    if (layout == H5D_VIRTUAL)
        throw Error(ErrorCode::UnsupportedFeature,
                    what + ": a virtual dataset (its data lives in other files); tetlod reads data stored in the file");

    const int external = H5Pget_external_count(dcpl);
    if (external > 0) {
        // Raw data in other files: each must be a regular file next to the HDF5
        // file (no absolute paths, no ..), and together they must hold the samples.
        const std::filesystem::path dir = std::filesystem::path(file).parent_path();
        uint64_t present = 0;
        for (int i = 0; i < external; ++i) {
            char name[4096] = {0};
            off_t offset = 0;
            hsize_t size = 0;
            if (H5Pget_external(dcpl, static_cast<unsigned>(i), sizeof name - 1, name, &offset, &size) < 0)
                throw Error(ErrorCode::CorruptData, what + ": unreadable external storage list");
            const std::filesystem::path p(name);
            bool outside = p.empty() || p.is_absolute();
            for (const auto& part : p) outside = outside || part == "..";
            if (outside)
                throw Error(ErrorCode::UnsupportedFeature,
                            what + ": external raw-data file '" + std::string(name) +
                                "' lies outside the HDF5 file's folder; tetlod does not read it");
            const std::string full = (dir / p).string();
            require_regular_file(full, "external raw-data file of " + what);
            std::error_code ec;
            const uint64_t fsize = std::filesystem::file_size(full, ec);
            if (!ec && offset >= 0 && static_cast<uint64_t>(offset) < fsize)
                present += std::min<uint64_t>(size, fsize - static_cast<uint64_t>(offset));
        }
        if (present < declared_bytes)
            throw Error(ErrorCode::Truncated, what + ": the external raw-data files hold " + std::to_string(present) +
                                                  " of the " + std::to_string(declared_bytes) + " bytes declared");
        return;
    }

    if (layout == H5D_CHUNKED) {
        hsize_t chunk[H5S_MAX_RANK] = {0};
        const int rank = H5Pget_chunk(dcpl, H5S_MAX_RANK, chunk);
        uint64_t chunk_bytes = element_bytes;
        for (int a = 0; a < rank; ++a) {
            if (chunk[a] == 0 || chunk_bytes > (uint64_t{1} << 40) / chunk[a])
                throw Error(ErrorCode::CorruptData, what + ": invalid chunk dimensions");
            chunk_bytes *= chunk[a];
        }
        const uint64_t stored = H5Dget_storage_size(dataset);
        if (stored > file_size)
            throw Error(ErrorCode::Truncated, what + ": the dataset's chunks claim " + std::to_string(stored) +
                                                  " bytes, the file has " + std::to_string(file_size));
        const uint64_t allowed = stored * kMaxCompressionRatio + kUnstoredAllowanceBytes;
        if (declared_bytes > allowed)
            throw Error(ErrorCode::TooLarge,
                        what + ": the dataset declares " + std::to_string(declared_bytes) + " bytes of samples but " +
                            "stores only " + std::to_string(stored) + " bytes of chunks (more than " +
                            std::to_string(kMaxCompressionRatio) +
                            "x compression or unwritten chunks); refused before allocating");
        if (chunk_bytes > std::max<uint64_t>(declared_bytes, uint64_t{16} << 20))
            throw Error(ErrorCode::TooLarge, what + ": one chunk declares " + std::to_string(chunk_bytes) +
                                                 " bytes, more than the whole dataset");
    }
}

}  // namespace tetlod::hdf5_guard
