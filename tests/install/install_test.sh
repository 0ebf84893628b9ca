#!/usr/bin/env bash
# install.Prefix: gonio installed with `cmake --install` into a temporary prefix outside the source
# and build trees, used from there with GONIO_DATA_DIR unset and no build folder on PATH, then the
# prefix moved to another folder and used again: the programs, the Python module, the example
# consumer built with find_package(gonio) and the same source built with pkg-config.
# A copy of the prefix without its share/gonio must fail to find the data: the programs have no
# other way to the data (no path of the source or build tree in any installed file).
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
. "$here/common.sh"
python=${GONIO_PYTHON:-/usr/bin/python3}
work=$(mktemp -d "${TMPDIR:-/tmp}/gonio-install.XXXXXX")
trap 'rm -rf "$work"' EXIT
case $work in "$source"/* | "$build"/*) fail "the temporary folder $work is inside the tree" ;; esac

EXPECTED_EVAL=$(eval_row "$build/tools")
[ -n "$EXPECTED_EVAL" ] || fail "the build's gonio eval printed nothing"
prefix=$work/prefix
cmake --install "$build" --prefix "$prefix" >"$work/install.log" 2>&1 || { cat "$work/install.log"; fail "cmake --install"; }

# The layout.
libdir=$(dirname "$(find "$prefix" -name libgonio_brdf.a)")
pydir=$(dirname "$(dirname "$(find "$prefix" -path '*/gonio/__init__.py')")")
with_python=${GONIO_WITH_PYTHON:-ON}
for f in bin/gonio bin/gonio-full share/gonio/materials/ngan2005.json share/gonio/rigs/sim4.json \
  share/gonio/devices/generic.json share/gonio/models/plastic-ggx.json \
  share/gonio/examples/consumer/CMakeLists.txt share/gonio/examples/python/fit_material.py \
  share/gonio/udev/70-gonio-usb3vision.rules share/gonio/gonio-device-access \
  share/man/man1/gonio.1 share/man/man1/gonio-eval.1 share/man/man1/gonio-acquire.1 \
  include/gonio/version.h include/gonio/brdf/rgl_bsdf.h include/gonio/fitting/fit.h \
  share/doc/gonio/install.md; do
  [ -e "$prefix/$f" ] || fail "$f is not installed"
done
for m in base brdf fitting batch devices sim acquisition report; do
  [ -f "$libdir/libgonio_$m.a" ] || fail "libgonio_$m.a is not installed"
done
for f in cmake/gonio/gonioConfig.cmake cmake/gonio/gonioConfigVersion.cmake cmake/gonio/gonioTargets.cmake \
  pkgconfig/gonio.pc; do
  [ -f "$libdir/$f" ] || fail "${libdir#"$prefix"/}/$f is not installed"
done
if [ "$with_python" = ON ]; then
  ls "$pydir"/gonio/_gonio*.so >/dev/null || fail "the Python module is not installed"
fi
# No installed file names the source or the build tree.
if found=$(grep -rlF "$source" "$prefix"); then fail "installed files name $source: $found"; fi
# The man page of a command carries that command's usage line.
usage=$("$prefix/bin/gonio" eval --help | sed -n 's/^Usage: //p')
[ -n "$usage" ] && grep -qxF "$usage" "$prefix/share/man/man1/gonio-eval.1" ||
  fail "gonio-eval.1 lacks the usage line \"$usage\" of gonio eval --help"

# Without share/gonio the data are not found, and nothing of the trees is tried.
cp -a "$prefix" "$work/nodata"
rm -rf "$work/nodata/share/gonio"
if out=$(cd "$work" && env -u GONIO_DATA_DIR "$work/nodata/bin/gonio" eval material:red-plastic </dev/null 2>&1); then
  fail "gonio eval found its data without share/gonio: $out"
fi
echo "$out" | grep -q 'not found' || fail "unexpected message without share/gonio: $out"
case $out in *"$source"*) fail "the installed gonio tried the source tree: $out" ;; esac
rm -rf "$work/nodata"

# gonio finds gonio-full in the install's libexec/gonio when it is not beside it, and says where it
# looked when it is nowhere.
cp -a "$prefix" "$work/split"
mkdir -p "$work/split/libexec/gonio"
mv "$work/split/bin/gonio-full" "$work/split/libexec/gonio/"
out=$(cd "$work" && env -u GONIO_DATA_DIR "$work/split/bin/gonio" sim --help) ||
  fail "gonio did not run libexec/gonio/gonio-full"
echo "$out" | grep -q '^Usage: .*sim' || fail "gonio sim --help through libexec/gonio/gonio-full: $out"
rm "$work/split/libexec/gonio/gonio-full"
status=0
out=$("$work/split/bin/gonio" sim --help 2>&1) || status=$?
[ "$status" -eq 1 ] || fail "gonio without gonio-full: exit status $status, not 1"
case $out in *"$work/split/bin/gonio-full"*"$work/split/bin/../libexec/gonio/gonio-full"*) ;;
  *) fail "gonio without gonio-full does not list where it looked: $out" ;; esac
rm -rf "$work/split"

mkdir -p "$work/run"
check_installed "$prefix/bin" "$work/run"

# The prefix moved to another folder, at another depth.
moved=$work/moved/opt/gonio
mkdir -p "$(dirname "$moved")"
mv "$prefix" "$moved"
libdir=$moved/${libdir#"$prefix"/}
pydir=$moved/${pydir#"$prefix"/}
check_installed "$moved/bin" "$work/run"

# The Python module of the moved prefix, with its data.
[ "$with_python" != ON ] || (
  unset GONIO_DATA_DIR
  cd "$work"
  PYTHONPATH=$pydir PYTHONDONTWRITEBYTECODE=1 "$python" -c '
import sys, gonio
assert gonio.__file__.startswith(sys.argv[1]), gonio.__file__
assert "red-plastic" in gonio.materials(), gonio.materials()
' "$moved/" || fail "import gonio from $pydir"
  PYTHONPATH=$pydir PYTHONDONTWRITEBYTECODE=1 "$python" "$moved/share/gonio/examples/python/fit_material.py" \
    >"$work/python.out" || fail "examples/python/fit_material.py"
  compare_columns "$work/python.out" python 0.001
)

# The example consumer: find_package(gonio), then the same source with pkg-config.
rgl=$work/red-plastic.bsdf
"$moved/bin/gonio" convert material:red-plastic "$rgl" >/dev/null || fail "gonio convert to $rgl"
cmake -S "$moved/share/gonio/examples/consumer" -B "$work/consumer" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$moved" >"$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "configure the consumer"; }
cmake --build "$work/consumer" >>"$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "build the consumer"; }
fit_options="model=beckmann;shadowing=v-groove"  # the structure of red-plastic
"$work/consumer/fit-rgl" "$rgl" "$fit_options" >"$work/consumer.out" || fail "fit-rgl $rgl"
compare_columns "$work/consumer.out" consumer 0.01
# shellcheck disable=SC2046
c++ -std=c++17 -O1 -o "$work/fit-rgl-pc" "$moved/share/gonio/examples/consumer/main.cpp" \
  $(PKG_CONFIG_PATH=$libdir/pkgconfig pkg-config --cflags --libs gonio) || fail "build the consumer with pkg-config"
"$work/fit-rgl-pc" "$rgl" "$fit_options" >"$work/consumer-pc.out" || fail "fit-rgl (pkg-config) $rgl"
cmp -s "$work/consumer.out" "$work/consumer-pc.out" || fail "the pkg-config build printed another fit"
echo "install.Prefix: installed, moved, used (programs, Python, find_package, pkg-config)"
