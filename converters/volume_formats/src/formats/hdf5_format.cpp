// Table entry for HDF5 datasets (FILE.h5:/path), present only when
// tetlod_hdf5_io is built. A name without a dataset writes /volume.
#include "tetlod/converters/features.hpp"
#include "tetlod/converters/volume_format.hpp"
#if TETLOD_HAVE_HDF5
#include "tetlod/converters/hdf5.hpp"
#endif

namespace tetlod {

VolumeFormat hdf5_volume_format() {
    VolumeFormat f;
    f.name = "h5";
    f.aliases = {"hdf5"};
    f.extensions = {".h5", ".hdf5", ".he5"};
    f.description = "HDF5 dataset FILE.h5:/path (default /volume)";
    f.not_built_hint = "HDF5 (configure with -DTETLOD_WITH_HDF5=ON)";
    f.datasets = true;
#if TETLOD_HAVE_HDF5
    f.read = [](const VolumeLocation& l, const VolumeReadOptions& o) { return read_hdf5(l.file, l.dataset, o); };
    f.open_planes = [](const VolumeLocation& l, const VolumeReadOptions& o) {
        return open_hdf5_planes(l.file, l.dataset, o);
    };
    f.write = [](const Volume& v, const VolumeLocation& l) {
        write_hdf5(v, l.file, l.dataset.empty() ? "/volume" : l.dataset);
    };
    f.write_planes = [](VolumePlanes& planes, const VolumeLocation& l) {
        write_hdf5(planes, l.file, l.dataset.empty() ? "/volume" : l.dataset);
    };
    f.lost_metadata = hdf5_unstorable_keys;
    f.check_output = [](const VolumeLocation& l) { check_hdf5_output(l.file, l.dataset.empty() ? "/volume" : l.dataset); };
#else
    f.built = false;
#endif
    return f;
}

}  // namespace tetlod
