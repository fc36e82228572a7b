#!/usr/bin/env bash
# Installs brainshift's build and test dependencies from Debian 12 packages.
# Idempotent: packages already present are skipped; apt runs only when something is missing.
# Usage: scripts/install_deps.sh            (as root, or with sudo available)
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config ninja-build
  libeigen3-dev          # dense/sparse linear algebra
  libsuitesparse-dev     # CHOLMOD supernodal Cholesky
  libopenblas-pthread-dev  # the BLAS under CHOLMOD: 2-3x ATLAS's speed (cmake/deps/blas.cmake)
  libcgal-dev            # meshing, spatial queries
  libgdcm-dev            # DICOM series in and out (imaging/io/dicom_io.cpp)
  libgdcm-tools          # gdcminfo, gdcmdump: GDCM's CMake package names them (no warnings)
  dcmtk                  # tests: dcmdump reads our DICOM series back (an independent reader)
  libopencv-dev          # 2-D image work, overlays
  libvtk9-dev            # medical image and mesh I/O
  libceres-dev           # rigid initialisation
  libgtest-dev libgmock-dev  # tests
  libbenchmark-dev       # micro-benchmarks
  libspdlog-dev libfmt-dev   # logging
  nlohmann-json3-dev     # JSON reports, scenes
  libcli11-dev           # command line
  libopenigtlink-dev     # brainshift serve: OpenIGTLink server for Slicer, client of PLUS
  zlib1g-dev
  libisal-dev            # optional: ISA-L's igzip, ~4x faster .nii.gz writing than zlib
  python3                # tests: the OpenIGTLink test client (tests/apps/igtl_client.py), written from the protocol
  calculix-ccx           # independent FEM reference for verification tests
  elastix                # the bench's image-registration peer (bench --elastix; not linked)
  gnuplot-nox            # benchmark plots
  clang-format           # scripts/lint.sh: formatting checked by scripts/test.sh (CI)
  clang-tidy             # scripts/lint.sh --tidy: the naming rules of .clang-tidy (on demand)
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install_deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
