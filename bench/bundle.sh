#!/usr/bin/env bash
# Packs what the GPU benchmarks and the engine tests need for a machine without Debian's packages (a lent
# GPU machine with another distribution): the built binaries, their shared libraries but glibc and the C++
# runtime (the target's own, newer ones serve), OpenVDB's vdb_render and vdb_print, and the Python client.
# Unpacked at the repository root there, it gives build/... and .gpu/{lib,bin,py}; bench/gpu_remote.sh
# does that and runs them.
#
#   bench/bundle.sh [--build DIR (default build)] [--out FILE (default .gpu/bundle.tar.xz)]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=build out=.gpu/bundle.tar.xz
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build=$2 ;;
    --out) out=$2 ;;
    *) echo "usage: $0 [--build DIR] [--out FILE]" >&2; exit 2 ;;
  esac
  shift 2
done
cd "$root"
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
tests=(runtime_test fft_test ocean/ocean_engine_test ocean/ocean_service_test ewave/ewave_test
       ewave/ewave_service_test clouds/clouds_test clouds/clouds_service_test textures/textures_test
       textures/textures_service_test textures/deform_test textures/river_test)
bins=("$build/squalld" "$build/squall" "$build"/bench/*_bench "$build/bench/load_client")
for t in "${tests[@]}"; do bins+=("$build/tests/$t"); done
tools=()
for tool in vdb_render vdb_print; do
  path=$(command -v "$tool") || { echo "$0: $tool not found (Debian: openvdb-tools)" >&2; exit 1; }
  tools+=("$path")
done
mkdir -p "$stage/.gpu/lib" "$stage/.gpu/bin" "$stage/.gpu/py"
for b in "${bins[@]}"; do
  to="$stage/build/${b#"$build"/}"
  mkdir -p "$(dirname "$to")" && cp "$b" "$to" && strip --strip-unneeded "$to"
done
cp "${tools[@]}" "$stage/.gpu/bin/"
for b in "${bins[@]}" "${tools[@]}"; do ldd "$b"; done | awk '/=>/ {print $3}' | sort -u |
  grep -v -E '/(libc|libm|libpthread|libdl|librt|libstdc\+\+|libgcc_s|ld-linux-x86-64)\.so' |
  while read -r lib; do cp -L "$lib" "$stage/.gpu/lib/"; done
strip --strip-unneeded "$stage"/.gpu/lib/* 2>/dev/null || true
cp -r "$build"/tests/python/venv/lib/python3*/site-packages/squall "$stage/.gpu/py/"
find "$stage" -name __pycache__ -prune -exec rm -rf {} +
mkdir -p "$(dirname "$out")"
printf '%s\n' "${tests[@]}" >"$stage/.gpu/tests.txt"
echo "$root" >"$stage/.gpu/source_dir"  # where the binaries look for the checkout's files
tar -C "$stage" -cJf "$out" build .gpu
ls -la "$out"
