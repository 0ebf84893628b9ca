#!/usr/bin/env bash
# Set-up (packages, configure, build), then the main job on the embedded simulated rig:
#   1. a point-mode campaign of a real material (Modbus drives + GigE Vision camera, simulated),
#   2. the fit of its dataset by automatic model choice (gonio fit's default, --model auto: the demo
#      material is Beckmann with V-groove shadowing, which a GGX fit misses in its dark blue channel),
#   3. plots, a ground-truth-versus-fit preview and the HTML report,
#   4. an image-mode campaign (a sphere of the same material, imaged by the simulated GigE Vision
#      camera through the same device path) straight into a half/difference table, the fit of that
#      table and its HTML report (coverage map, holes, calibration).
# Everything lands in $GONIO_OUT (default gonio-out/) under a new time-stamped folder.
# Environment: GONIO_MATERIAL (default red-plastic; any name of data/materials/ngan2005.json).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
gonio="${BUILD_DIR:-build}/tools/gonio"
material=${GONIO_MATERIAL:-red-plastic}
run="${GONIO_OUT:-gonio-out}/$(date +%Y%m%d-%H%M%S)"
dir="$run/campaign"
mkdir -p "$run"

step() { printf '\n== %s\n' "$*"; }

step "1/4 point-mode campaign of $material on the embedded simulated rig"
"$gonio" acquire --material "$material" --out "$dir"

step "2/4 fit (automatic model choice)"
"$gonio" fit "$dir/dataset.csv" --out "$dir/fit.json"

step "3/4 plots, preview, report"
"$gonio" plot "$dir/dataset.csv" --fit "$dir/fit.json" --out "$dir/plots"
mkdir -p "$dir/previews"
"$gonio" preview "material:$material" --vs "$dir/fit.json" --out "$dir/previews/truth-vs-fit.png"
"$gonio" report "$dir"

step "4/4 image-mode campaign of $material (sphere sample), its fit and report"
"$gonio" acquire --mode image --material "$material" --out "$run/image"
"$gonio" fit "$run/image/dataset.csv" --out "$run/image/fit.json"
"$gonio" report "$run/image"

printf '\nDone.\n  dataset: %s\n  fit:     %s\n  report:  %s\n  image-mode report: %s\n' \
  "$dir/dataset.csv" "$dir/fit.report.json" "$dir/report.html" "$run/image/report.html"
