#!/usr/bin/env bash
# On a GPU machine without Debian's packages, from the repository root, with the bundle of bench/bundle.sh
# at .gpu/bundle.tar.xz: unpacks it, points the OpenCL ICD loader at NVIDIA's driver, and runs the stages
# named in STAGES (default "bench tests"):
#   readback  bench/readback_bench: a tile's planes read back, pageable and pinned;
#   profile   ocean_bench with SQUALL_PROFILE_KERNELS=1: the device time of each kernel;
#   bench     bench/gpu_run.sh: the GPU benchmarks and their goals;
#   load      bench/load_bench.py alone (LOAD_SECONDS a level, default 3);
#   tests     the engine and service test binaries on the GPU (SQUALL_TEST_DEVICE=gpu), all at once.
# Results go to OUT (default gpu-out): the benchmarks' outputs, and res.tar.gz with the machine's
# description and the tests' logs. Binaries that read files by the build's absolute paths find them through
# a link from the build machine's source directory (.gpu/source_dir) to this checkout, made where nothing
# is there.
#
#   STAGES="bench tests" bench/gpu_remote.sh
set -u
cd "$(dirname "$0")/.." || exit
OUT=${OUT:-gpu-out}
mkdir -p "$OUT"
stages=" ${STAGES:-bench tests} "
t0=$(date +%s)
elapsed() { echo "[+$(($(date +%s) - t0)) s]"; }
has() { [[ $stages == *" $1 "* ]]; }

tar -xJf .gpu/bundle.tar.xz || python3 -c "import tarfile; tarfile.open('.gpu/bundle.tar.xz').extractall()"
source_dir=$(cat .gpu/source_dir)
[ -e "$source_dir" ] || { mkdir -p "$(dirname "$source_dir")" && ln -s "$PWD" "$source_dir"; }
export LD_LIBRARY_PATH=$PWD/.gpu/lib PATH=$PWD/.gpu/bin:$PATH PYTHONPATH=$PWD/.gpu/py:$PWD/bench
export POCL_CACHE_DIR=/tmp/pocl-cache PYTHONUNBUFFERED=1
res=$(mktemp -d)/res
mkdir -p "$res/tests"
save() { tar -C "$(dirname "$res")" -czf "$OUT/res.tar.gz" res; }

icd=$(find /usr/local/nvidia /usr/lib /usr/lib64 /lib /usr/local/lib -name 'libnvidia-opencl.so*' 2>/dev/null | head -1)
if [ -n "$icd" ]; then  # else the machine's own ICD files
  mkdir -p /tmp/icd && echo "$icd" >/tmp/icd/nvidia.icd
  export OCL_ICD_VENDORS=/tmp/icd
fi
{
  nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.mem,memory.total --format=csv
  head -3 /etc/os-release
  echo "cores: $(nproc); NVIDIA OpenCL: ${icd:-none}"
  python3 -c 'import grpc, google.protobuf, numpy; print(grpc.__version__, google.protobuf.__version__, numpy.__version__)'
  for b in build/squalld build/bench/* build/tests/*_test build/tests/*/*_test .gpu/bin/*; do
    ldd "$b" | grep "not found" | sed "s|^|$b: |"
  done
} >"$res/machine.txt" 2>&1
cat "$res/machine.txt"
save

if has readback; then
  timeout 60 build/bench/readback_bench --device gpu >"$OUT/readback.txt" 2>&1
  echo "readback rc=$?"; grep -v INFO "$OUT/readback.txt"; elapsed
fi
if has profile; then
  SQUALL_PROFILE_KERNELS=1 timeout 90 build/bench/ocean_bench --device gpu --seconds 1 >"$OUT/ocean_profile.txt" 2>&1
  echo "profile rc=$?"; grep -v INFO "$OUT/ocean_profile.txt"; elapsed
fi
if has bench; then
  timeout "${BENCH_S:-330}" bash bench/gpu_run.sh --device gpu --out "$OUT/gpu-run" --python python3 >"$res/gpu_run.txt" 2>&1
  echo "gpu_run rc=$?"; grep -h -E "goal|FAILED" "$OUT"/gpu-run/*.txt; save; elapsed
fi
if has load; then
  timeout "${LOAD_S:-200}" python3 bench/load_bench.py --seconds "${LOAD_SECONDS:-3}" --squalld build/squalld \
    --squalld-flags "--device gpu" >"$OUT/load_bench.txt" 2>&1
  echo "load rc=$?"; tail -n 12 "$OUT/load_bench.txt"; elapsed
fi
if has tests; then
  mapfile -t tests <.gpu/tests.txt  # the test binaries the bundle holds, under build/tests/
  for t in "${tests[@]}"; do  # all at once: correctness, not speed
    log="$res/tests/$(basename "$t").txt"
    (SQUALL_TEST_DEVICE=gpu timeout "${TEST_S:-150}" "build/tests/$t" >"$log" 2>&1; echo "rc=$?" >>"$log") &
  done
  wait
  for t in "${tests[@]}"; do
    log="$res/tests/$(basename "$t").txt"
    echo "$(basename "$t") $(tail -1 "$log") $(grep -E '^\[  (PASSED|FAILED)  \] [0-9]+ test' "$log" | tr '\n' ' ')"
    grep -E '^\[  FAILED  \] [A-Z].*\(' "$log" | head -6 | cut -c1-150
  done
  save; elapsed
fi
