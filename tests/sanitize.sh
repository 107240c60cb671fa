#!/usr/bin/env bash
# The sanitizer job: a clang build (AddressSanitizer, LeakSanitizer, libFuzzer coverage) of squalld and a
# subset of the tests in BUILD_DIR (default ./build-asan), then: the runtime and common unit tests (the
# runtime's also with its buffers made as a GPU's: pinned blocks, their mappings and the views that hold
# them), the clouds service tests against the instrumented squalld (cancelled renders and builds), the
# bad-input sweep of every RPC against it, and the four libFuzzer harnesses over request validation for
# SQUALL_FUZZ_SECONDS each (default 30). Any sanitizer report, leak included, fails the job.
# Needs the main build (./build, deploy/build.sh): its Python venv and its PoCL kernel cache.
# Usage: tests/sanitize.sh [BUILD_DIR]
set -euo pipefail
source_dir=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$source_dir/build-asan}
main_build=$source_dir/build
reports=$build/sanitizer-reports

mkdir -p "$build"
cmake -S "$source_dir" -B "$build" -DCMAKE_BUILD_TYPE=Debug -DSQUALL_FUZZ=ON \
  -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  "-DCMAKE_CXX_FLAGS=-O1 -fsanitize=address,fuzzer-no-link -fno-omit-frame-pointer" \
  "-DCMAKE_C_FLAGS=-O1 -fsanitize=address -fno-omit-frame-pointer" "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address" \
  "-DSQUALL_TEST_CACHE_DIR=$main_build/pocl-cache" > "$build/configure.log"
cmake --build "$build" -j "$(nproc)" --target squalld squall runtime_test common_test clouds_service_test \
  ocean_fuzz ewave_fuzz clouds_fuzz textures_fuzz

rm -rf "$reports"
mkdir -p "$reports"
# new_delete_type_mismatch=0: Debian's clFFT deletes its plans' actions through a base pointer of another
# size (FFTRepo::deletePlan), which would abort every squalld that times the clfft backend at start-up.
export ASAN_OPTIONS="log_path=$reports/asan:detect_leaks=1:abort_on_error=0:new_delete_type_mismatch=0"
export LSAN_OPTIONS="suppressions=$source_dir/tests/support/lsan.supp:print_suppressions=0"
status=0
ctest --test-dir "$build" --output-on-failure \
  -R '^(runtime_test(_device_buffers)?|common_test|clouds_service_test|(ocean|ewave|clouds|textures)_fuzz)$' || status=1
(cd "$source_dir/tests/python" &&
  SQUALL_SQUALLD="$build/squalld" SQUALL_CLI="$build/squall" POCL_CACHE_DIR="$main_build/pocl-cache" \
    PYTHONDONTWRITEBYTECODE=1 "$main_build/tests/python/venv/bin/python" -m pytest -q -p no:cacheprovider \
    test_bad_input.py) || status=1
if compgen -G "$reports/asan.*" > /dev/null; then
  echo "sanitizer reports:"
  cat "$reports"/asan.*
  status=1
fi
exit $status
