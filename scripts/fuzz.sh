#!/usr/bin/env bash
# Builds every libFuzzer target with clang-14 (-fsanitize=fuzzer,address,undefined) in its own build
# folder and runs each for SECONDS (default 60), one after the other at low priority. New inputs that
# reach new code go to the run's folder; with MERGE=1 they are merged into fuzz/corpus/<target>.
# Every finding (crash, leak, timeout, out-of-memory) is copied into fuzz/corpus/<target>/ so that
# the corpus replay in ctest runs it from then on, and makes the script exit 1.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]      targets: the names in fuzz/CMakeLists.txt (csv, gvcp, ...)
# Environment: FUZZ_BUILD_DIR (default build-fuzz), JOBS (build jobs, default: number of cores),
# MERGE (1: merge new coverage into the corpus), FUZZ_ARGS (more libFuzzer options), FUZZ_SKIP_BUILD
# (1: run the targets as already built in the build folder), FUZZ_PARALLEL (targets run at once, default 1).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
case "$seconds" in
  ''|*[!0-9]*) echo "fuzz.sh: SECONDS must be a whole number of seconds, got '$seconds'" >&2; exit 2 ;;
esac
build_dir=${FUZZ_BUILD_DIR:-build-fuzz}
jobs=${JOBS:-$(nproc)}

# The target list is the one CMake builds (one source of truth).
all_targets=$(sed -n 's/^set(gonio_fuzz_targets \(.*\))$/\1/p' fuzz/CMakeLists.txt)
if [ $# -gt 0 ]; then
  targets="$*"
  for t in $targets; do
    case " $all_targets " in *" $t "*) ;; *) echo "fuzz.sh: unknown target '$t' (targets: $all_targets)" >&2; exit 2 ;; esac
  done
else
  targets=$all_targets
fi

for tool in clang-14 clang++-14; do
  command -v "$tool" >/dev/null || { echo "fuzz.sh: $tool not found (scripts/setup.sh installs clang-14 and libclang-rt-14-dev)" >&2; exit 1; }
done

binary() { echo "$build_dir/fuzz/gonio_fuzz_$1"; }
if [ "${FUZZ_SKIP_BUILD:-0}" != 1 ]; then
  # GONIO_BUILD_FUZZ instruments every library for coverage and the sanitizers (CMakeLists.txt).
  # Warnings are the gcc build's gate (-Werror there); clang's own warnings do not stop fuzzing.
  # Build type Instrumented: -O1 with line tables only (a quicker build; findings still come with file
  # and line).
  cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Instrumented \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DGONIO_BUILD_FUZZ=ON -DGONIO_BUILD_TESTS=OFF -DGONIO_BUILD_PYTHON=OFF -DGONIO_WERROR=OFF >/dev/null
  build_targets=()
  for t in $targets; do build_targets+=("gonio_fuzz_$t"); done
  nice -n 10 cmake --build "$build_dir" -j "$jobs" --target "${build_targets[@]}"
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# Runs one target; its summary line goes to $run_dir/summary, and it returns 1 on a finding.
fuzz_one() {
  local t=$1
  local run_dir="$build_dir/fuzz/run/$t"
  rm -rf "$run_dir"
  mkdir -p "$run_dir/new" "$run_dir/artifacts"
  local corpus="fuzz/corpus/$t"
  local log="$run_dir/log.txt"
  echo "fuzz.sh: $t for ${seconds} s (log $log)"
  # -timeout: one input that takes 30 s on this machine is a finding (a hang), not patience.
  # -report_slow_units at the same bound: below it a slow unit is the machine's load (it is written
  # as an artifact otherwise, from 10 s on), above it the timeout reports it.
  local rc=0
  nice -n 10 "$(binary "$t")" -max_total_time="$seconds" -timeout=30 -report_slow_units=30 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$run_dir/artifacts/" ${FUZZ_ARGS:-} \
    "$run_dir/new" "$corpus" >"$log" 2>&1 || rc=$?
  local execs
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  local findings=0 f
  for f in "$run_dir"/artifacts/*; do
    [ -e "$f" ] || continue
    findings=$((findings + 1))
    cp "$f" "$corpus/finding-$(basename "$f")"
    echo "fuzz.sh: $t: finding $(basename "$f") copied into $corpus/"
  done
  if [ "$rc" -ne 0 ] && [ "$findings" -eq 0 ]; then
    findings=1
    echo "fuzz.sh: $t: libFuzzer exited $rc without an artifact; see $log"
  fi
  if [ "$findings" -gt 0 ]; then
    tail -n 40 "$log"
  fi
  if [ "${MERGE:-0}" = 1 ]; then
    nice -n 10 "$(binary "$t")" -merge=1 "$corpus" "$run_dir/new" >>"$log" 2>&1
  fi
  echo "$t: ${seconds} s, ${execs:-0} executions, $findings findings" >"$run_dir/summary"
  [ "$findings" -eq 0 ]
}

# FUZZ_PARALLEL targets at a time (default 1).
parallel=${FUZZ_PARALLEL:-1}
case "$parallel" in
  ''|*[!0-9]*|0) echo "fuzz.sh: FUZZ_PARALLEL must be a whole number above 0, got '$parallel'" >&2; exit 2 ;;
esac
status=0
running=0
for t in $targets; do
  if [ "$running" -ge "$parallel" ]; then
    wait -n || status=1
    running=$((running - 1))
  fi
  fuzz_one "$t" &
  running=$((running + 1))
done
while [ "$running" -gt 0 ]; do
  wait -n || status=1
  running=$((running - 1))
done
for t in $targets; do
  cat "$build_dir/fuzz/run/$t/summary" 2>/dev/null | sed 's/^/fuzz.sh: /' || echo "fuzz.sh: $t: no summary"
done
exit $status
