#!/usr/bin/env bash
# install.DebianPackage: the Debian package built with cpack, installed with apt, used from /usr
# (programs, Python module, data), the opt-in device access granted and revoked, the package
# removed and purged: afterwards neither a file of the package nor any path naming gonio is left
# in /usr, /etc or dpkg's database. Needs root, apt-get and dpkg-shlibdeps; skips (exit 77) with
# the reason otherwise, or when a gonio is already installed (it would be replaced, then removed).
set -euo pipefail
build=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
. "$here/common.sh"
skip() {
  echo "SKIP: $*"
  exit 77
}
[ "$(id -u)" -eq 0 ] || skip "installs a package: needs root"
command -v apt-get >/dev/null || skip "needs apt-get"
command -v dpkg-shlibdeps >/dev/null || skip "needs dpkg-shlibdeps (Debian package dpkg-dev)"
if dpkg-query -W -f='${Status}' gonio 2>/dev/null | grep -q installed; then
  skip "a gonio package is installed on this machine"
fi
[ ! -e /usr/bin/gonio ] || skip "/usr/bin/gonio exists"

# apt waits for dpkg's lock (a fresh machine's daily apt run may hold it) rather than failing at once.
apt_get=(apt-get -o DPkg::Lock::Timeout=600)
work=$(mktemp -d "${TMPDIR:-/tmp}/gonio-deb.XXXXXX")
cleanup() {
  if dpkg-query -W -f='${Status}' gonio 2>/dev/null | grep -q installed; then
    "${apt_get[@]}" purge -y -qq gonio >/dev/null 2>&1 || true
  fi
  rm -rf "$work"
}
trap cleanup EXIT

listing() {
  find /usr /etc /var/lib/dpkg/info -xdev -path /etc/ld.so.cache -prune -o -print 2>/dev/null | sort
}

EXPECTED_EVAL=$(eval_row "$build/tools")
(cd "$build" && cpack -G DEB -B "$work/package" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; fail "cpack -G DEB"; }
deb=$(ls "$work"/package/gonio_*.deb)
depends=$(dpkg-deb -f "$deb" Depends)
# (Ceres is linked statically: its own libraries, glog and SuiteSparse, stand for it.)
for lib in libgoogle-glog libcholmod libaravis libmodbus libusb libopencv-core libopenexr libcpp-httplib; do
  echo "$depends" | grep -q "$lib" || fail "the package's Depends lacks $lib: $depends"
done
[ "${GONIO_WITH_PYTHON:-ON}" != ON ] || case $depends in *"python3 (>= 3."*"python3-numpy"*) ;;
  *) fail "the package's Depends lacks python3 or python3-numpy: $depends" ;; esac
contents=$(dpkg-deb -c "$deb")
if echo "$contents" | grep ' \./etc/'; then fail "the package installs into /etc (above)"; fi
echo "$contents" | grep ' \./usr/bin/gonio-full$' >/dev/null || fail "the package lacks /usr/bin/gonio-full"

groups_before=$(id -nG root)
listing >"$work/before"
(cd "$work/package" && DEBIAN_FRONTEND=noninteractive "${apt_get[@]}" install -y -qq "./$(basename "$deb")" \
  >"$work/apt.log" 2>&1) || { cat "$work/apt.log"; fail "apt install ./$(basename "$deb")"; }
[ ! -e /etc/udev/rules.d/70-gonio-usb3vision.rules ] || fail "the package installed the udev rule itself"
mkdir -p "$work/run"
check_installed /usr/bin "$work/run"
# As a user would: bytecode written beside the module (the package's prerm takes it away again).
[ "${GONIO_WITH_PYTHON:-ON}" != ON ] || (cd "$work" && env -u PYTHONPATH -u PYTHONDONTWRITEBYTECODE "${GONIO_PYTHON:-/usr/bin/python3}" -c '
import gonio
assert gonio.__file__.startswith("/usr/"), gonio.__file__
assert "red-plastic" in gonio.materials()
') || fail "import gonio from /usr"
[ "${GONIO_WITH_PYTHON:-ON}" != ON ] || ls -d /usr/lib/python3*/dist-packages/gonio/__pycache__ >/dev/null ||
  fail "the import wrote no bytecode"
[ -f /usr/share/man/man1/gonio-fit.1 ] || fail "no man page gonio-fit(1)"

# The opt-in device access, then revoked.
access=/usr/share/gonio/gonio-device-access
"$access" grant root >"$work/grant.log" || { cat "$work/grant.log"; fail "gonio-device-access grant root"; }
[ "$(readlink /etc/udev/rules.d/70-gonio-usb3vision.rules)" = /usr/share/gonio/udev/70-gonio-usb3vision.rules ] ||
  fail "grant did not link the udev rule"
id -nG root | tr ' ' '\n' | grep -qx plugdev || fail "grant did not add root to plugdev"
id -nG root | tr ' ' '\n' | grep -qx dialout || fail "grant did not add root to dialout"
"$access" revoke root >/dev/null || fail "gonio-device-access revoke root"
[ ! -e /etc/udev/rules.d/70-gonio-usb3vision.rules ] || fail "revoke left the udev rule"
[ "$(id -nG root)" = "$groups_before" ] || fail "revoke left root in $(id -nG root) (before: $groups_before)"
# A rule granted and never revoked goes with the package.
"$access" grant root >/dev/null
for g in plugdev dialout; do
  case " $groups_before " in *" $g "*) ;; *) gpasswd -d root "$g" >/dev/null ;; esac
done

dpkg -L gonio >"$work/files"
DEBIAN_FRONTEND=noninteractive "${apt_get[@]}" remove -y -qq gonio >"$work/apt.log" 2>&1 || { cat "$work/apt.log"; fail "apt-get remove gonio"; }
[ ! -e /etc/udev/rules.d/70-gonio-usb3vision.rules ] || fail "the removal left the udev rule"
while read -r f; do
  [ "$f" = /. ] || [ -d "$f" ] || [ ! -e "$f" ] || fail "the removal left $f"
done <"$work/files"
DEBIAN_FRONTEND=noninteractive "${apt_get[@]}" purge -y -qq gonio >"$work/apt.log" 2>&1 || { cat "$work/apt.log"; fail "apt-get purge gonio"; }
listing >"$work/after"
# Other work on the machine may add files meanwhile; what matters is that none of them is gonio's.
diff "$work/before" "$work/after" >"$work/diff" || true
if grep -i gonio "$work/diff"; then fail "left on the machine after the purge (above)"; fi
echo "install.DebianPackage: $(basename "$deb") installed, used from /usr, removed without leftovers"
