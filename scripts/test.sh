#!/usr/bin/env bash
# Sets everything up, then runs the whole test suite: the Release build's tests (unit and,
# where a device exists, GPU), then the unit tests again under AddressSanitizer and
# UndefinedBehaviorSanitizer. Any failure or sanitizer report fails the run.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --sanitize

echo "== tests (Release) ==" >&2
ctest --test-dir build --output-on-failure -j "$(nproc)"

echo "== unit tests under ASan + UBSan ==" >&2
export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" -L unit
echo "test: all passed" >&2
