// Parallel HDF5 writes (see tetlod/converters/hdf5_mpi_write.hpp): the serial
// writer's staging, dataset and attributes (hdf5_dataset_write.cpp), given the
// MPI-IO file driver and a collective transfer list.
#include "tetlod/converters/hdf5_mpi_write.hpp"

#include "hdf5_dataset_write.hpp"
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/output_policy.hpp"

#ifndef H5_HAVE_PARALLEL
#error "hdf5_mpi_write.cpp needs the parallel HDF5 library (libhdf5-openmpi-dev)"
#endif

namespace tetlod {

using namespace hdf5_detail;

Hdf5MpiStaging::Hdf5MpiStaging(const std::string& file, const std::string& dataset) {
    silence_hdf5();
    // The serial checks, on this rank alone (the default driver, read-only):
    // refusals come before any rank opens anything, so no rank is left
    // waiting in a collective call for one that refused.
    const std::string d = normalize_dataset(dataset);
    check_hdf5_output(file, d);
    StagedOutput out = stage_output(file, d, active_output_policy());
    path_ = std::move(out.path);
    update_ = out.update;
}

Hdf5MpiStaging::~Hdf5MpiStaging() = default;

const std::string& Hdf5MpiStaging::temp_path() const { return path_->temp_path(); }

void Hdf5MpiStaging::commit() { path_->commit(); }

namespace {

class Hdf5MpiWriter final : public Hdf5MpiDatasetWriter {
public:
    Hdf5MpiWriter(Hid file, Hid dataset, Hid dxpl, Volume header, std::string what)
        : f_(std::move(file)), d_(std::move(dataset)), dxpl_(std::move(dxpl)), header_(std::move(header)),
          what_(std::move(what)) {}

    void write_planes(int64_t z0, int64_t count, const std::byte* src) override {
        const Dims dims = header_.dims;
        if (z0 < 0 || count < 0 || count > dims.z || z0 > dims.z - count)
            throw Error(ErrorCode::InvalidArgument, what_ + ": planes " + std::to_string(z0) + ".." +
                                                        std::to_string(z0 + count - 1) + " outside the volume");
        Hid fs(H5Dget_space(d_.get()), H5Sclose);
        Hid ms;
        bool selected = fs.valid();
        const std::byte unused[8] = {};
        if (count == 0) {
            // An empty selection: a collective write needs every rank's call.
            const hsize_t one = 1;
            ms = Hid(H5Screate_simple(1, &one, nullptr), H5Sclose);
            selected = selected && ms.valid() && H5Sselect_none(fs.get()) >= 0 && H5Sselect_none(ms.get()) >= 0;
            src = unused;
        } else {
            // The dataset is (Z, Y, X): planes z0.. are its rows z0... The
            // memory space has the selection's shape (fast mapping).
            const hsize_t start[3] = {hsize_t(z0), 0, 0};
            const hsize_t size[3] = {hsize_t(count), hsize_t(dims.y), hsize_t(dims.x)};
            ms = Hid(H5Screate_simple(3, size, nullptr), H5Sclose);
            selected = selected && ms.valid() &&
                       H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start, nullptr, size, nullptr) >= 0;
        }
        if (!selected || H5Dwrite(d_.get(), native_type(header_.type), ms.get(), fs.get(), dxpl_.get(), src) < 0)
            throw Error(ErrorCode::IoError, what_ + ": cannot write planes " + std::to_string(z0) + ".." +
                                                std::to_string(z0 + count - 1) + ": " + hdf5_error_text());
    }

    void finish() override {
        write_volume_attributes(d_.get(), header_, what_);
        d_.reset();
        if (H5Fflush(f_.get(), H5F_SCOPE_GLOBAL) < 0)
            throw Error(ErrorCode::IoError, what_ + ": cannot flush the file: " + hdf5_error_text());
        f_.reset();  // collective; the flush above wrote everything
    }

private:
    Hid f_, d_, dxpl_;
    Volume header_;
    std::string what_;
};

}  // namespace

std::unique_ptr<Hdf5MpiDatasetWriter> create_hdf5_mpi(const std::string& temp, bool update, const std::string& file,
                                                      const std::string& dataset_in, const Volume& header,
                                                      MPI_Comm comm) {
    silence_hdf5();
    const std::string dataset = normalize_dataset(dataset_in);
    const std::string what = name_of(file, dataset);
    validate_dims(header.dims, what);
    Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
    Hid dxpl(H5Pcreate(H5P_DATASET_XFER), H5Pclose);
    if (!fapl.valid() || !dxpl.valid() || H5Pset_fapl_mpio(fapl.get(), comm, MPI_INFO_NULL) < 0 ||
        H5Pset_dxpl_mpio(dxpl.get(), H5FD_MPIO_COLLECTIVE) < 0)
        throw Error(ErrorCode::IoError, "'" + file + "': cannot set up MPI-IO: " + hdf5_error_text());
    Hid f = open_output_file(temp, update, fapl.get(), file, what);
    // The serial writer's dataset, contiguous (what `tetlod decode` writes);
    // the staging rank already applied the output policy (null here).
    Hid d = create_volume_dataset(f.get(), file, dataset, header, Hdf5WriteOptions{}, update, nullptr, what);
    return std::make_unique<Hdf5MpiWriter>(std::move(f), std::move(d), std::move(dxpl), header, what);
}

}  // namespace tetlod
