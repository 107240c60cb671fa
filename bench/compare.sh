#!/usr/bin/env bash
# Runs the benchmarks of two build trees alternately (A B A B) on the same machine, so that a change can be
# compared with its parent within the machine's noise. Each tree uses its own PoCL cache and its own
# squalld for the eWave stream. Nothing else should run on the cores meanwhile.
#   bench/compare.sh OLD_BUILD_DIR NEW_BUILD_DIR [ROUNDS] > results.txt
set -euo pipefail
old=$1 new=$2 rounds=${3:-2}

run_tree() {  # label build_dir
  local label=$1 dir=$2 port_file
  export POCL_CACHE_DIR=$dir/pocl-cache
  port_file=$(mktemp)
  "$dir/squalld" --listen 127.0.0.1:0 --port-file "$port_file" --fft vkfft 2>/dev/null &
  local pid=$!
  for _ in $(seq 600); do [ -s "$port_file" ] && break; sleep 0.1; done
  sleep 2  # health turns SERVING after the kernels are built; the bench's first call waits anyway
  echo "=== $label: fft_bench"; "$dir/bench/fft_bench" --runs 21
  echo "=== $label: ocean_bench"; "$dir/bench/ocean_bench" --seconds 2
  echo "=== $label: ewave_bench"; "$dir/bench/ewave_bench" --fft vkfft --address "127.0.0.1:$(cat "$port_file")" --seconds 2
  echo "=== $label: clouds_bench"; "$dir/bench/clouds_bench" 256
  kill "$pid"; wait "$pid" 2>/dev/null || true
  rm -f "$port_file"
}

for round in $(seq "$rounds"); do
  echo "##### round $round"
  run_tree parent "$old"
  run_tree change "$new"
done
