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
# (1: run the targets as already built in the build folder).
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
  # -O1 with line tables only: a quicker build (CI builds it from nothing), and findings still
  # come with file and line.
  cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DGONIO_BUILD_FUZZ=ON -DGONIO_BUILD_TESTS=OFF -DGONIO_BUILD_PYTHON=OFF -DGONIO_WERROR=OFF >/dev/null
  build_targets=()
  for t in $targets; do build_targets+=("gonio_fuzz_$t"); done
  nice -n 10 cmake --build "$build_dir" -j "$jobs" --target "${build_targets[@]}"
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
status=0
summary=()
for t in $targets; do
  run_dir="$build_dir/fuzz/run/$t"
  rm -rf "$run_dir"
  mkdir -p "$run_dir/new" "$run_dir/artifacts"
  corpus="fuzz/corpus/$t"
  log="$run_dir/log.txt"
  echo "fuzz.sh: $t for ${seconds} s (log $log)"
  # -timeout: one input that takes 30 s on this machine is a finding (a hang), not patience.
  set +e
  nice -n 10 "$(binary "$t")" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$run_dir/artifacts/" ${FUZZ_ARGS:-} \
    "$run_dir/new" "$corpus" >"$log" 2>&1
  rc=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  findings=0
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
    status=1
    tail -n 40 "$log"
  fi
  if [ "${MERGE:-0}" = 1 ]; then
    nice -n 10 "$(binary "$t")" -merge=1 "$corpus" "$run_dir/new" >>"$log" 2>&1
  fi
  summary+=("$t: ${seconds} s, ${execs:-0} executions, $findings findings")
done
printf 'fuzz.sh: %s\n' "${summary[@]}"
exit $status
