#!/usr/bin/env bash
# unilod main job on the bundled demo data (README Quick start).
# Installs missing Debian packages, builds (optimised), then runs the pipeline as far as it exists
# today on the Jacksboro DEM + GRASS river network: the unified LOD model (.ulod), its full check,
# its summary, the paper's Tables 2/3 for it, and the improved 3D_DP importance order of the whole point set as CSV. Later stages
# (capture, bench, report) join here as they land.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
source tools/deps.sh
unilod_ensure_packages

cmake --preset default >/dev/null
cmake --build --preset default -j "$(nproc)"
unilod=build/tools/unilod
dem=assets/jacksboro_dem.tif
rivers=assets/jacksboro_rivers_grass.geojson
mkdir -p out

echo "== 1. unilod build: DEM + rivers -> unified LOD model =="
$unilod build "$dem" "$rivers" -o out/jacksboro.ulod --force "$@"
echo "== 2. unilod check: checksums + topology invariants at every stored level =="
$unilod check -q out/jacksboro.ulod
echo "== 3. unilod info =="
$unilod info out/jacksboro.ulod
echo "== 4. unilod stats: the paper's Table 2 / 3 for this model (1-3 pixels, 100-1500 km) =="
$unilod stats out/jacksboro.ulod --pixels 1,2,3
echo "== 5. unilod order: improved 3D_DP importance order of the whole point set =="
$unilod order "$dem" "$rivers" --out out/jacksboro_order.csv -q
echo "== outputs =="
echo "  unified LOD model: $root/out/jacksboro.ulod"
echo "  importance order:  $root/out/jacksboro_order.csv"
