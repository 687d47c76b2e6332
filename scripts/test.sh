#!/usr/bin/env bash
# Sets everything up, then runs the whole test suite: the Release build's tests (unit and,
# where a device exists, GPU), then the unit tests again under AddressSanitizer and
# UndefinedBehaviorSanitizer (all but the main job end to end, which the optimised run covers:
# it alone was 5 of the sanitized run's 14 minutes; and there the calibration fit tests fit a
# smaller synthetic sample set, 20 samples for 53, asserting the same of it: DTFLOP_TEST_SMALL_FITS,
# tests/calibrate/synthetic.hpp; the Release run fits the full set), then the fuzz targets, built
# in the same sanitized clang tree (scripts/setup.sh). Any failure or sanitizer report fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
# clang (and libFuzzer) come with scripts/setup.sh's packages.
scripts/setup.sh --sanitize --fuzz

echo "== tests (Release) ==" >&2
ctest --test-dir build --output-on-failure -j "$(nproc)"

echo "== unit tests under ASan + UBSan ==" >&2
export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp"  # the runtime libraries' own (libomp)
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -L unit -E '^MainJob\.'
# Each libFuzzer target for DTFLOP_FUZZ_SECONDS (5 s) from its corpus, one after another (about
# 10 s each with loading and the leak check; ctest stops one at 2 minutes over); a crash, leak,
# timeout or sanitizer report fails the run (the input that did it is left in
# build-asan/fuzz/artifacts/).
echo "== fuzz targets (libFuzzer, bounded) ==" >&2
ctest --test-dir build-asan --output-on-failure -L fuzz
echo "test: all passed" >&2
