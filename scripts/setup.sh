#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures and builds gonio.
# Environment: BUILD_DIR (default build), GONIO_SANITIZE (ON/OFF), GONIO_BUILD_BENCH (ON/OFF),
# GONIO_WERROR (default ON), BUILD_TYPE (default Release: -O2
# without debug information, about a third less build time; RelWithDebInfo adds -g), JOBS (default: number of cores),
# CMAKE_ARGS (more cmake options, e.g. another compiler).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/phase.sh

packages=(cmake make g++ pkg-config git
  libceres-dev libeigen3-dev libopencv-dev libopenexr-dev libmodbus-dev libusb-1.0-0-dev
  iproute2 googletest libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev
  libspdlog-dev libfmt-dev libexpected-dev
  libaravis-dev aravis-tools-cli aravis-tools
  pybind11-dev python3-dev python3-numpy python3-pytest python3-scipy
  python3-distributed python3-dask python3-pymodbus python3-serial python3-serial-asyncio
  libxsimd-dev libcpp-httplib-dev chromium ccache blender
  clang-14 libclang-rt-14-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
phase_start
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  # apt waits for dpkg's lock (a fresh machine's daily apt run may hold it) rather than failing.
  "${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}"
fi

phase_end "packages"

build_dir=${BUILD_DIR:-build}
jobs=${JOBS:-$(nproc)}
# ccache (where installed) keys compilations by paths relative to the source folder, so that another
# clone of the project on the same machine reuses what this one compiled.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
phase_start
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=${BUILD_TYPE:-Release} \
  -DGONIO_WERROR=${GONIO_WERROR:-ON} -DGONIO_SANITIZE=${GONIO_SANITIZE:-OFF} \
  -DGONIO_BUILD_BENCH=${GONIO_BUILD_BENCH:-OFF} ${CMAKE_ARGS:-} >/dev/null
cmake --build "$build_dir" -j "$jobs"
phase_end "build $build_dir"
