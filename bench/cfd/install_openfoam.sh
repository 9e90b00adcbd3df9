#!/usr/bin/env bash
# OpenFOAM is needed only by the CFD benchmark in this folder (not by the build or CI).
# Debian's package is OpenFOAM v1912 (openfoam.com); its tools land in /usr/bin
# (blockMesh, snappyHexMesh, checkMesh, simpleFoam, ...).
set -euo pipefail
if command -v simpleFoam >/dev/null 2>&1; then
  echo "openfoam already installed: $(command -v simpleFoam)"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO=sudo
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends openfoam
