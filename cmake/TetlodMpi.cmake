# TETLOD_WITH_MPI (AUTO, ON, OFF): the distributed converter tetlod-mpi (mpi/)
# needs MPI and the *parallel* HDF5 library (Debian: libopenmpi-dev,
# libhdf5-openmpi-dev). AUTO builds it when both are found; ON fails loudly
# when one is missing; OFF never looks. Sets TETLOD_MPI_ENABLED.
#
# The parallel HDF5 is found through pkg-config (hdf5-openmpi.pc) and kept in
# its own imported target, never through FindHDF5: FindHDF5 serves the serial
# converter (tetlod_hdf5_io), and one program must never load both libhdf5
# builds (same symbols, different libraries).
set(TETLOD_WITH_MPI AUTO CACHE STRING "Build tetlod-mpi (MPI + parallel HDF5): AUTO, ON or OFF")
set_property(CACHE TETLOD_WITH_MPI PROPERTY STRINGS AUTO ON OFF)
set(TETLOD_MPI_ENABLED OFF)
string(TOUPPER "${TETLOD_WITH_MPI}" _tetlod_mpi_mode)
if(NOT _tetlod_mpi_mode MATCHES "^(AUTO|ON|OFF|TRUE|FALSE|YES|NO|1|0)$")
  message(FATAL_ERROR "TETLOD_WITH_MPI='${TETLOD_WITH_MPI}': expected AUTO, ON or OFF")
endif()
if(_tetlod_mpi_mode MATCHES "^(OFF|FALSE|NO|0)$")
  return()
endif()
if(NOT TETLOD_WITH_HDF5)
  if(_tetlod_mpi_mode STREQUAL "AUTO")
    message(STATUS "tetlod-mpi: not built (TETLOD_WITH_HDF5 is OFF)")
    return()
  endif()
  message(FATAL_ERROR "TETLOD_WITH_MPI is ON but TETLOD_WITH_HDF5 is OFF (tetlod-mpi reads HDF5)")
endif()

find_package(MPI COMPONENTS C CXX QUIET)
find_package(PkgConfig QUIET)
set(_tetlod_phdf5_found FALSE)
if(PkgConfig_FOUND)
  # Debian names the module hdf5-openmpi; other systems hdf5-mpi or hdf5_openmpi.
  pkg_search_module(TETLOD_PHDF5 QUIET IMPORTED_TARGET GLOBAL hdf5-openmpi hdf5_openmpi hdf5-mpi)
  if(TETLOD_PHDF5_FOUND)
    find_file(_tetlod_phdf5_conf H5pubconf.h PATHS ${TETLOD_PHDF5_INCLUDE_DIRS} NO_DEFAULT_PATH)
    if(_tetlod_phdf5_conf)
      file(STRINGS ${_tetlod_phdf5_conf} _tetlod_phdf5_parallel REGEX "#define H5_HAVE_PARALLEL 1")
      if(_tetlod_phdf5_parallel)
        set(_tetlod_phdf5_found TRUE)
      endif()
    endif()
    unset(_tetlod_phdf5_conf CACHE)
  endif()
endif()

if(MPI_C_FOUND AND MPI_CXX_FOUND AND _tetlod_phdf5_found)
  set(TETLOD_MPI_ENABLED ON)
  find_program(TETLOD_MPIEXEC NAMES ${MPIEXEC_EXECUTABLE} mpirun mpiexec)
  message(STATUS "tetlod-mpi: MPI ${MPI_CXX_VERSION}, parallel HDF5 ${TETLOD_PHDF5_VERSION} "
                 "(${TETLOD_PHDF5_INCLUDE_DIRS})")
elseif(_tetlod_mpi_mode STREQUAL "AUTO")
  message(STATUS "tetlod-mpi: not built (needs MPI and parallel HDF5: libopenmpi-dev "
                 "libhdf5-openmpi-dev; -DTETLOD_WITH_MPI=ON makes this an error)")
else()
  set(_missing "")
  if(NOT (MPI_C_FOUND AND MPI_CXX_FOUND))
    string(APPEND _missing " MPI (libopenmpi-dev, openmpi-bin)")
  endif()
  if(NOT _tetlod_phdf5_found)
    string(APPEND _missing " parallel HDF5 (libhdf5-openmpi-dev: pkg-config module hdf5-openmpi "
                           "with H5_HAVE_PARALLEL)")
  endif()
  message(FATAL_ERROR "TETLOD_WITH_MPI is ON but these were not found:${_missing}. Install them "
                      "(scripts/install-deps.sh does), or configure with -DTETLOD_WITH_MPI=OFF.")
endif()
