# Shared by install_test.sh and deb_test.sh: the checks run against an installed gonio.
# check_installed BIN_DIR WORK_DIR: runs --version, eval, acquire and fit with the installed programs
# only (GONIO_DATA_DIR unset, no build folder on PATH).

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

# The first data row of `gonio eval material:red-plastic` at theta_i = 0.5, theta_o = 0.5 (mirror),
# which the build tree's gonio also printed.
eval_row() {
  printf 'theta_i,phi_i,theta_o,phi_o\n0.5,0,0.5,3.141592653589793\n0.3,0,0.7,0\n' |
    "$1/gonio" eval material:red-plastic | tail -n 2
}

check_installed() {
  local bin=$1 work=$2
  (
    unset GONIO_DATA_DIR PYTHONPATH
    cd "$work"
    "$bin/gonio" --version | grep -Eq '^gonio [0-9]+\.[0-9]+\.[0-9]+ \(commit ' ||
      fail "$bin/gonio --version: $("$bin/gonio" --version)"
    [ "$(eval_row "$bin")" = "$EXPECTED_EVAL" ] ||
      fail "$bin/gonio eval material:red-plastic printed $(eval_row "$bin"), the build printed $EXPECTED_EVAL"
    rm -rf "$work/campaign"
    "$bin/gonio" acquire --time-scale 1000 --out "$work/campaign" >"$work/acquire.log" 2>&1 ||
      { cat "$work/acquire.log"; fail "$bin/gonio acquire"; }
    [ -s "$work/campaign/dataset.csv" ] || fail "no dataset.csv in $work/campaign"
    "$bin/gonio" fit "$work/campaign/dataset.csv" --out "$work/fit.json" >"$work/fit.log" 2>&1 ||
      { cat "$work/fit.log"; fail "$bin/gonio fit"; }
    grep -q '"lobes"' "$work/fit.json" || fail "$work/fit.json holds no model"
  )
}

# compare_columns FILE NAME TOLERANCE: rows "theta r g b r' g' b'" (a reference, then a fit of the
# reference's own model structure): every fitted value within TOLERANCE (relative) of the reference.
compare_columns() {
  awk -v name="$2" -v tol="$3" 'NR > 1 {
      rows++
      for (c = 2; c <= 4; c++) {
        ref = $c; fit = $(c + 3)
        if (ref <= 0 || fit <= 0 || (fit - ref) / ref > tol || (ref - fit) / ref > tol) {
          printf "%s: theta_o %s column %d: reference %s, fit %s\n", name, $1, c, ref, fit; bad = 1
        }
      }
    }
    END { if (rows < 9) { print name ": fewer than 9 rows"; bad = 1 } exit bad }' "$1" ||
    { cat "$1"; fail "$2: the fit is not within $3 of the reference"; }
}
