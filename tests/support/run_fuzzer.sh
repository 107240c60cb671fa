#!/usr/bin/env bash
# Runs one libFuzzer harness for SQUALL_FUZZ_SECONDS (default 30), starting from its checked-in seeds;
# new inputs go to a scratch corpus. A finding leaves its input (crash-*, timeout-*, oom-*) in that
# directory: fix the code, then add the input to the seeds, which every run replays first.
# Usage: run_fuzzer.sh FUZZER SEEDS_DIR SCRATCH_DIR
set -euo pipefail
fuzzer=$1 seeds=$2 scratch=$3
rm -rf "$scratch"
mkdir -p "$scratch/corpus"
cd "$scratch"
exec "$fuzzer" -max_total_time="${SQUALL_FUZZ_SECONDS:-30}" -seed=1 -timeout=10 -rss_limit_mb=4096 \
  -max_len=65536 -print_final_stats=1 "$scratch/corpus" "$seeds"
