#!/usr/bin/env bash
# The benchmarks to run on a GPU, in one go, with their goals collected at the end: fft_bench, ocean_bench,
# ewave_bench, clouds_bench (the cumulus at 1920x1080) and the load benchmark, each on --device (default
# gpu: NVIDIA's OpenCL platform where the machine has one, PoCL's CUDA device otherwise). Each benchmark's
# output goes to OUT/<name>.txt; every line of them that states a goal ("goal on a GPU: ...", the CPU goals
# of the same benchmarks) is printed last.
#
#   bench/gpu_run.sh [--device gpu|cpu|NAME] [--build DIR (default build)] [--out DIR (default gpu-run)]
#                    [--seconds S (per measurement, default 2)] [--python PY (default the tests' venv)]
#
# It builds nothing: build the project first (README). On a CPU device it runs too, slowly, and shows the
# same figures for this machine. A benchmark that fails is reported and the others still run; the exit
# status is then 1.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
device=gpu build="$root/build" out=gpu-run seconds=2 python=
while [ $# -gt 0 ]; do
  case "$1" in
    --device) device=$2 ;;
    --build) build=$2 ;;
    --out) out=$2 ;;
    --seconds) seconds=$2 ;;
    --python) python=$2 ;;
    *) echo "usage: $0 [--device D] [--build DIR] [--out DIR] [--seconds S] [--python PY]" >&2; exit 2 ;;
  esac
  shift 2
done
python=${python:-$build/tests/python/venv/bin/python}
mkdir -p "$out"
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$build/pocl-cache}

failed=0
run() {  # run NAME COMMAND...: the command's output to OUT/NAME.txt and to the terminal
  local name=$1
  shift
  echo "== $name: $*"
  if ! "$@" 2>&1 | tee "$out/$name.txt"; then
    echo "== $name FAILED (exit ${PIPESTATUS[0]})" | tee -a "$out/$name.txt"
    failed=1
  fi
}

run fft_bench "$build/bench/fft_bench" --device "$device"
run ocean_bench "$build/bench/ocean_bench" --device "$device" --seconds "$seconds"
run ewave_bench "$build/bench/ewave_bench" --device "$device" --seconds "$seconds"
run clouds_bench "$build/bench/clouds_bench" --device "$device" --image 1920x1080 256
run load_bench "$python" "$root/bench/load_bench.py" --seconds 5 \
  --squalld "$build/squalld" --squalld-flags "--device $device"

echo
echo "== goals ($out/*.txt)"
grep -h "goal" "$out"/*.txt || true
exit $failed
