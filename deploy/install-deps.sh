#!/usr/bin/env bash
# Installs everything squall needs to build, run and test on Debian 12 (bookworm).
# Idempotent: packages already present are left alone. Used by the README, .ci/run and the container image.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git ca-certificates
  # OpenCL: the ICD loader, PoCL (the embedded CPU device), the C++ bindings
  ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers pocl-opencl-icd clinfo
  # FFT backends and the reference
  libclfft-dev libvkfft-dev libfftw3-dev
  # Sparse volumes and images
  libopenvdb-dev libnanovdb-dev libopenvdb-tools libopenexr-dev libpng-dev
  libboost-dev  # OpenVDB's headers include Boost (numeric conversion)
  # RPC
  libgrpc++-dev libprotobuf-dev protobuf-compiler protobuf-compiler-grpc
  # Tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
