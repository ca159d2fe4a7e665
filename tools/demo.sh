#!/usr/bin/env bash
# unilod main job on the bundled demo data (README Quick start).
# Installs missing Debian packages, builds (optimised), then runs the pipeline as far as it exists
# today: the improved 3D_DP importance order of the Jacksboro DEM + GRASS river network, printed as
# a summary. Later stages (build .ulod, check, capture, bench, report) join here as they land.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
source tools/deps.sh
unilod_ensure_packages

cmake --preset default >/dev/null
cmake --build --preset default -j "$(nproc)"
mkdir -p out
echo "== unilod order: Jacksboro DEM + GRASS rivers (improved 3D_DP with BAI) =="
build/tools/unilod order assets/jacksboro_dem.tif assets/jacksboro_rivers_grass.geojson \
    --out out/jacksboro_order.csv "$@"
echo "== outputs =="
echo "  importance order: $root/out/jacksboro_order.csv"
