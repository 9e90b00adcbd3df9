#!/usr/bin/env bash
# Installs the Debian 12 packages voxpack needs, only those that are missing.
# Idempotent: when everything is present it only runs dpkg-query (seconds).
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config clang-format ccache
  libinsighttoolkit5-dev libeigen3-dev libfftw3-dev libhdf5-dev libcgal-dev zlib1g-dev
  libgtest-dev libgmock-dev libomp-dev
  libcli11-dev nlohmann-json3-dev libtomlplusplus-dev
  python3-matplotlib python3-numpy python3-scipy python3-h5py
  chromium
  libopenmpi-dev openmpi-bin libhdf5-openmpi-dev
  pybind11-dev python3-dev python3-pytest python3-vtk9 python3-meshio python3-tifffile
  clang libfuzzer-14-dev libclang-rt-14-dev
)

missing=()
for p in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "setup-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
echo "setup-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup-deps: done"
