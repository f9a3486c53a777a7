#!/usr/bin/env bash
# Usage: install_test.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX [PYTHON]
# Installs BUILD_DIR into WORK_DIR/prefix and checks the prefix on its own.
set -euo pipefail
build=$1 source=$2 work=$3 cxx=$4 python=${5:-}
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix
step() { echo "== $*"; }

step "install into $prefix"
cmake --install "$build" --prefix "$prefix" >"$work/install.log"
for f in bin/tetlod lib/cmake/tetlod/tetlodConfig.cmake lib/cmake/tetlod/tetlodConfigVersion.cmake \
         lib/cmake/tetlod/tetlodTargets.cmake lib/pkgconfig/tetlod.pc include/tetlod/tetlod.hpp \
         include/tetlod/version.hpp include/tetlod/converters/features.hpp \
         include/tetlod/core/error.hpp lib/libtetlod_core.a; do
  [ -e "$prefix/$f" ] || { echo "missing from the install: $f"; exit 1; }
done

step "the installed CLI needs nothing from the build tree"
if ldd "$prefix/bin/tetlod" | grep -v "=> $prefix/" | grep -e "not found" -e "$build"; then
  echo "bin/tetlod resolves libraries outside the prefix (above)"; exit 1
fi
readelf -d "$prefix/bin/tetlod" | grep -E "RUNPATH|RPATH"
"$prefix/bin/tetlod" --version
"$prefix/bin/tetlod" -q sample sphere "$work/sphere.raw" --size 17
"$prefix/bin/tetlod" -q convert "$work/sphere.raw" "$work/sphere.tlod" --dims 17,17,17 --dtype u8
"$prefix/bin/tetlod" extract "$work/sphere.tlod" "$work/sphere.vtu" --error 1%
[ -s "$work/sphere.vtu" ]

step "examples/ with find_package(tetlod)"
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
cmake -S "$source/examples" -B "$work/examples" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_PREFIX_PATH="$prefix" >"$work/examples-configure.log"
cmake --build "$work/examples" >"$work/examples-build.log"
"$work/examples/tetlod_example" "$work/example.vtu"
[ -s "$work/example.vtu" ]

step "examples/ with pkg-config"
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
# shellcheck disable=SC2046  # pkg-config prints several words on purpose
"$cxx" -O1 -o "$work/example_pc" "$source/examples/lod_example.cpp" $(pkg-config --cflags --libs tetlod)
"$work/example_pc" "$work/example_pc.vtu"
cmp "$work/example.vtu" "$work/example_pc.vtu"

if [ -n "$python" ]; then
  step "the Python module from the prefix"
  site=$prefix/lib/python3/dist-packages
  PYTHONPATH=$site "$python" -c "
import sys, tetlod
assert tetlod.__file__.startswith('$site'), tetlod.__file__
mesh = tetlod.extract('$work/sphere.tlod', error='1%')
assert mesh.tets.shape[1] == 4 and mesh.tets.shape[0] > 0
print('python: tetlod', tetlod.__version__, mesh)
"
fi
echo "install_prefix: ok"
