#!/usr/bin/env bash
# Set-up (packages, configure, build), then every test through ctest.
# Environment: as scripts/setup.sh, plus CTEST_ARGS (more ctest options, e.g. -L or -LE to choose a group)
# and TEST_JOBS (tests run at once; default twice the cores: most of the long tests wait on the simulated
# rig's motion, a peer's timeout or a child process, not on the processor).
# A test that fails runs once more (ctest --repeat until-pass:2): a test that fails twice fails the
# command; one that passes the second time is named at the end (scripts/ctest_skips.py) with its first
# failure, as depending on the machine's load, and its failed run's output stays in the log.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/phase.sh
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
jobs=${JOBS:-$(nproc)}
test_jobs=${TEST_JOBS:-$((2 * jobs))}
status=0
# The tests that stream frames through Aravis (label "stream") run each in a network namespace of its
# own where the build found one usable (root), beside all the others; elsewhere they run after the
# others, one at a time, with no other loopback traffic on the machine (cmake/GonioHelpers.cmake).
phase_start
if grep -q '^GONIO_TEST_NETNS:BOOL=ON$' "$build_dir/CMakeCache.txt"; then
  ctest --test-dir "$build_dir" --output-on-failure --repeat until-pass:2 -j "$test_jobs" ${CTEST_ARGS:-} || status=$?
  python3 scripts/ctest_skips.py "$build_dir"
else
  ctest --test-dir "$build_dir" --output-on-failure --repeat until-pass:2 -j "$test_jobs" -LE '^stream$' ${CTEST_ARGS:-} || status=$?
  python3 scripts/ctest_skips.py "$build_dir"
  ctest --test-dir "$build_dir" --output-on-failure --repeat until-pass:2 -j 1 -L '^stream$' ${CTEST_ARGS:-} || status=$?
  python3 scripts/ctest_skips.py "$build_dir"
fi
phase_end "tests $build_dir"
exit "$status"
