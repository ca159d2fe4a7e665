#!/usr/bin/env bash
# unilod main job on the bundled demo data (README Quick start): installs missing Debian packages,
# builds (optimised), then runs the whole chain on the Jacksboro DEM + GRASS river network:
#   build -> check -> info -> stats -> capture (perspective, top-down, 2D grid, path) -> bench
#   -> export (glTF) -> report -> importance order,
# and prints where every output is. On an interactive terminal with a display (or with --view)
# it then opens the viewer on the model.
#
# Options: --frames N   bench frames per run, also the report's frame-time plot (default 200;
#                       CI uses a handful)
#          --size WxH   bench frame size (default 1920x1080)
#          --out DIR    output folder (default out/)
#          --no-build   use the existing build (build/tools/unilod, or $UNILOD_BIN)
#          --view       open `unilod view` at the end (needs a display)
#          --no-view    never open the viewer
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
frames=200 size=1920x1080 out=out build=1 view=auto
while [ $# -gt 0 ]; do
    case "$1" in
        --frames) frames=$2; shift 2 ;;
        --size) size=$2; shift 2 ;;
        --out) out=$2; shift 2 ;;
        --no-build) build=0; shift ;;
        --view) view=1; shift ;;
        --no-view) view=0; shift ;;
        -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
        *) echo "tools/demo.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    esac
done

unilod=${UNILOD_BIN:-build/tools/unilod}
if [ "$build" = 1 ]; then
    source tools/deps.sh
    unilod_ensure_packages
    cmake --preset default >/dev/null
    cmake --build --preset default -j "$(nproc)"
    unilod=build/tools/unilod
fi
dem=assets/jacksboro_dem.tif
rivers=assets/jacksboro_rivers_grass.geojson
path=assets/jacksboro_path.json
orbit=assets/jacksboro_orbit.json
mkdir -p "$out"
model=$out/jacksboro.ulod
paper_model=$out/jacksboro_paper.ulod

echo "== 1. unilod build: DEM + rivers -> unified LOD model (64-cell blocks, 42 blocks) =="
$unilod build "$dem" "$rivers" -o "$model" --block-size 64 --overwrite
echo "-- the paper's configuration: improved 3D_DP order, the paper's error as default --"
$unilod build "$dem" "$rivers" -o "$paper_model" --block-size 64 --overwrite -q \
    --order 3ddp --metric paper
echo "== 2. unilod check: checksums, topology invariants and true errors at every stored level =="
$unilod check -q --errors "$model"
echo "== 3. unilod info =="
$unilod info "$model"
echo "== 4. unilod stats: the paper's Table 2 / 3 for this model (1-3 pixels, 100-1500 km) =="
$unilod stats "$model" --pixels 1,2,3
echo "== 5. unilod capture: headless frames (Vulkan; validation on) =="
$unilod capture "$model" --validation --size 1280x720 --camera 735000,4034000,3500,30,-20 \
    --annotate --overwrite -o "$out/capture/oblique"
$unilod capture "$model" --validation --size 1024x1024 --camera 746400,4052900,30000,0,-90 \
    --annotate --overwrite -o "$out/capture/topdown"
$unilod capture "$model" --validation --size 1024x1024 --camera 746400,4052900,30000,0,-90 \
    --grid --overwrite -o "$out/capture/grid"
$unilod capture "$model" --validation --size 640x360 --path "$path" --frames 5 \
    --overwrite -o "$out/capture/path"
echo "== 6. unilod bench: $frames frames at $size along $path (low fly-over) and $orbit =="
$unilod bench "$model" --path "$path" --frames "$frames" --size "$size" \
    --overwrite -o "$out/bench.json"
$unilod bench "$model" --path "$orbit" --frames "$frames" --size "$size" \
    --overwrite -o "$out/bench_orbit.json"
echo "-- the orbit in the paper's configuration (3ddp order, S to the block centre, the paper's"
echo "   error; no P-pixel guarantee): MEASURED.md, \"Engine\" --"
$unilod bench "$paper_model" --path "$orbit" --frames "$frames" --size "$size" \
    --metric paper --distance centre --overwrite -o "$out/bench_orbit_paper.json"
echo "== 7. unilod export: the oblique capture's LOD as glTF 2.0 (Blender, three.js) =="
$unilod export "$model" -q --camera 735000,4034000,3500,30,-20 --size 1280x720 \
    -o "$out/jacksboro_oblique.glb" --overwrite
echo "-- the whole model as a 3D Tiles 1.1 tileset on the WGS84 globe (CesiumJS) --"
$unilod export "$model" -q --3dtiles "$out/jacksboro_3dtiles" --overwrite
echo "== 8. unilod report: tables, error curves, BAI vs no BAI rivers, grid diagrams =="
$unilod report "$model" -q --overwrite -o "$out/report" --dem "$dem" --rivers "$rivers" \
    --bench-frames "$frames"
echo "-- the same for the paper's configuration (Tables 2/3 as in the paper) --"
$unilod report "$paper_model" -q --overwrite -o "$out/report_paper" --dem "$dem" --rivers "$rivers" \
    --bench-frames "$frames"
echo "== 9. unilod order: improved 3D_DP importance order of the whole point set =="
$unilod order "$dem" "$rivers" -o "$out/jacksboro_order.csv" --overwrite -q
echo "== outputs =="
echo "  unified LOD model:  $out/jacksboro.ulod (greedy order)"
echo "  paper's config:     $out/jacksboro_paper.ulod (3ddp order, paper metric)"
echo "  captures (PNG+JSON): $out/capture/{oblique,topdown,grid,path}/"
echo "  benchmark JSON:     $out/bench.json (fly-over), $out/bench_orbit.json (orbit),"
echo "                      $out/bench_orbit_paper.json (orbit, the paper's configuration)"
echo "  glTF export:        $out/jacksboro_oblique.glb"
echo "  3D Tiles tileset:   $out/jacksboro_3dtiles/tileset.json (CesiumJS, QGIS 3D)"
echo "  report:             $out/report/report.md (tables, curves, rivers, grid diagrams)"
echo "  paper's report:     $out/report_paper/report.md (3ddp order, paper metric)"
echo "  importance order:   $out/jacksboro_order.csv"
if [ "$view" = auto ]; then
    view=0
    [ -t 0 ] && [ -t 1 ] && [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ] && view=1
fi
if [ "$view" = 1 ]; then
    if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
        echo "== viewer: WASD + mouse, +/- tolerance, G grid, L rivers, P screenshot, Esc quits =="
        $unilod view "$model"
    else
        echo "(no display or no viewer: skipped)"
    fi
fi
