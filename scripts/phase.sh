# Sourced by the scripts: phase_start / phase_end NAME time a phase; with GONIO_PHASE_LOG set (as
# .ci/run does), each phase's name and seconds are appended to that file, one line each.
phase_start() { phase_t0=$SECONDS; }
phase_end() {
  local seconds=$((SECONDS - phase_t0))
  echo "phase: $1 took $seconds s"
  if [ -n "${GONIO_PHASE_LOG:-}" ]; then printf '%s\t%d\n' "$1" "$seconds" >> "$GONIO_PHASE_LOG"; fi
}
