#!/usr/bin/env bash
# Set-up (packages, configure, build), then every test through ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
# The tests that stream frames through Aravis (label "stream") run after the others, one at a time, with
# no other loopback traffic on the machine (cmake/GonioHelpers.cmake says why).
ctest --test-dir "$build_dir" --output-on-failure -j "${JOBS:-$(nproc)}" -LE '^stream$' ${CTEST_ARGS:-}
ctest --test-dir "$build_dir" --output-on-failure -j 1 -L '^stream$' ${CTEST_ARGS:-}
