#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build, and run the main job on
# the built-in sample: generate a volume, extract LOD meshes into ./out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
./build/tools/tetlod demo --out out
