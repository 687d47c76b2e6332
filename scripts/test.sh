#!/usr/bin/env bash
# Sets everything up, then runs the whole test suite: the Release build's tests, then the unit
# tests under AddressSanitizer and UndefinedBehaviorSanitizer (in a clang tree at -O2), then the
# fuzz targets, built in that same sanitized tree (scripts/setup.sh). Any failure or sanitizer
# report fails the run.
#
# Each test runs once where it checks most, not twice (docs/design.md, "The test suite and CI"):
# CI's clean clone on a 2-core machine took 29 minutes when the 551 unit tests were built and run
# in both trees (building them is about 400 of the Release build's 970 CPU-seconds, running them
# 4 of its 5 minutes of tests).
# - The sanitized tree runs the unit tests: everything they assert, and any memory error or
#   undefined behaviour besides. It leaves out the main job end to end (it alone was 5 of that run's
#   14 minutes) and the GPU tests (no CUDA there); there the calibration fit tests fit a smaller
#   synthetic sample set, 20 samples for 53, asserting the same of it (DTFLOP_TEST_SMALL_FITS,
#   tests/calibrate/synthetic.hpp).
# - Without a GPU, the Release tree builds and runs only what the sanitized tree cannot run or does
#   not check (--release-tests=optimised: DTFLOP_TESTS=optimised, CMakeLists.txt): the GPU tests
#   (built with the CUDA backends where nvcc is; they skip without a device), the install test, the
#   main job end to end, the calibration tests that fit the full sample set, and the fuzz corpus
#   replays (the sanitized tree has libFuzzer binaries instead). The trade-off: the other unit tests
#   no longer run against gcc's -O3 objects, only against clang's -O2 ones with the sanitizers;
#   the main job and the install test still exercise the Release build end to end.
# - With a GPU (nvidia-smi lists one), the Release tree builds and runs every test, as before: some
#   unit tests run the CUDA backends too where a device is (the workload contract, the DCT workload's
#   counts, the independent renderer's accuracy), which the sanitized tree, built without CUDA,
#   cannot.
set -euo pipefail
cd "$(dirname "$0")/.."
release_tests=optimised
if nvidia-smi -L 2>/dev/null | grep -q '^GPU'; then
  release_tests=all
fi
# clang (and libFuzzer) come with scripts/setup.sh's packages.
scripts/setup.sh --sanitize --fuzz --release-tests="$release_tests"

echo "== tests (Release: $release_tests) ==" >&2
ctest --test-dir build --output-on-failure -j "$(nproc)"

echo "== unit tests under ASan + UBSan ==" >&2
export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp"  # the runtime libraries' own (libomp)
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -L unit
# Each libFuzzer target for DTFLOP_FUZZ_SECONDS (5 s) from its corpus (about 10 s each with loading
# and the leak check; ctest stops one at 2 minutes over), as many at once as there are CPUs: each
# is one single-threaded process with its own work folder and corpus copy, so two on two CPUs each
# fuzz as long as one alone would; a crash, leak, timeout or sanitizer report fails the run (the
# input that did it is left in build-asan/fuzz/artifacts/).
echo "== fuzz targets (libFuzzer, bounded) ==" >&2
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -L fuzz
echo "test: all passed" >&2
