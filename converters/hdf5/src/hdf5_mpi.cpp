// Parallel HDF5 reads (see tetlod/converters/hdf5_mpi.hpp): the serial
// reader's open_hdf5_source and read_hdf5_planes, given the MPI-IO file
// driver and a collective transfer list.
#include "tetlod/converters/hdf5_mpi.hpp"

#include <filesystem>

#include "hdf5_dataset.hpp"
#include "hdf5_read_guard.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/regular_file.hpp"

#ifndef H5_HAVE_PARALLEL
#error "hdf5_mpi.cpp needs the parallel HDF5 library (libhdf5-openmpi-dev)"
#endif

namespace tetlod {

using namespace hdf5_detail;

namespace {

class Hdf5MpiSource final : public Hdf5MpiDataset {
public:
    Hdf5MpiSource(Hdf5Source src, Hid dxpl) : src_(std::move(src)), dxpl_(std::move(dxpl)) {}

    const Volume& header() const override { return src_.header; }

    void read_planes(int64_t z0, int64_t count, std::byte* dst) override {
        const int64_t z = src_.header.dims.z;
        if (z0 < 0 || count < 0 || count > z || z0 > z - count)
            throw Error(ErrorCode::InvalidArgument, src_.what + ": planes " + std::to_string(z0) + ".." +
                                                        std::to_string(z0 + count - 1) + " outside the volume");
        read_hdf5_planes(src_, z0, count, dst, scratch_, dxpl_.get());
    }

private:
    Hdf5Source src_;
    Hid dxpl_;
    std::vector<std::byte> scratch_;
};

}  // namespace

uint64_t check_hdf5_mpi_input(const std::string& file) {
    require_regular_file(file, "HDF5 file");
    std::error_code ec;
    const uint64_t file_size = std::filesystem::file_size(file, ec);
    if (ec) throw Error(ErrorCode::IoError, "cannot open '" + file + "': " + ec.message());
    hdf5_guard::check_hdf5_superblock(file, file_size);
    return file_size;
}

std::unique_ptr<Hdf5MpiDataset> open_hdf5_mpi(const std::string& file, const std::string& dataset,
                                              const VolumeReadOptions& options, uint64_t file_size,
                                              MPI_Comm comm) {
    silence_hdf5();
    Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
    Hid dxpl(H5Pcreate(H5P_DATASET_XFER), H5Pclose);
    if (!fapl.valid() || !dxpl.valid() || H5Pset_fapl_mpio(fapl.get(), comm, MPI_INFO_NULL) < 0 ||
        H5Pset_dxpl_mpio(dxpl.get(), H5FD_MPIO_COLLECTIVE) < 0)
        throw Error(ErrorCode::IoError, "'" + file + "': cannot set up MPI-IO: " + hdf5_error_text());
    // Every rank reads its planes once, in order: no chunk cache to size.
    Hdf5Source src = open_hdf5_source(file, dataset, options, file_size, /*for_planes=*/false, fapl.get());
    return std::make_unique<Hdf5MpiSource>(std::move(src), std::move(dxpl));
}

}  // namespace tetlod
