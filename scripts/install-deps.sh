#!/usr/bin/env bash
# Installs the Debian (bookworm) packages tetlod needs, only those missing.
# Needs root (or sudo) when anything is missing; does nothing otherwise.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libgtest-dev libbenchmark-dev
  libtbb-dev zlib1g-dev libzstd-dev zstd liblz4-dev liblzma-dev
  libcli11-dev nlohmann-json3-dev libxxhash-dev
  libopenvdb-dev libboost-iostreams-dev
  libhdf5-dev hdf5-tools
  # tetlod-mpi (TETLOD_WITH_MPI): MPI and the parallel HDF5, installed beside the
  # serial one (its own include and library folders under .../hdf5/openmpi; h5cc
  # stays the serial wrapper, so FindHDF5 still finds the serial library).
  libopenmpi-dev openmpi-bin libhdf5-openmpi-dev
  libzfp-dev  # optional: only bench_container's zfp peer (its columns say n/a without it)
  libopenmesh-dev
  clang libclang-rt-14-dev
  python3 python3-numpy python3-vtk9 python3-meshio python3-h5py gmsh
  pybind11-dev python3-dev python3-pytest
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
