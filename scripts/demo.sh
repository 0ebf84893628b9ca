#!/usr/bin/env bash
# Set-up (packages, configure, build), then the main job: a complete campaign on the embedded simulated rig,
# the fit, the plots, the previews and the report, written under gonio-out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
exec "$build_dir/tools/gonio" demo --out "${GONIO_OUT:-gonio-out}" "$@"
