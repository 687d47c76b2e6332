#!/usr/bin/env bash
# Builds executables for the lent GPU machine and gathers them, with the non-system shared
# libraries they need, into .carry/ (git-ignored; pass it as `carry` to the device tool).
#   scripts/device-bundle.sh TARGET...        e.g. dtflop test_rbe bench_rbe
# On the device:  export LD_LIBRARY_PATH=$PWD/.carry/lib; .carry/bin/dtflop probe
# The bundle must stay under the device tool's 64 MiB; OpenCV's image codecs alone pull in
# ~180 MiB of libraries, so build-device/ is configured without them (DTFLOP_DEVICE_BUNDLE).
set -euo pipefail
cd "$(dirname "$0")/.."
(($#)) || { echo "usage: $0 TARGET..." >&2; exit 2; }
cmake -S . -B build-device -G Ninja -DCMAKE_BUILD_TYPE=Release -DDTFLOP_DEVICE_BUNDLE=ON >/dev/null
cmake --build build-device -j "$(nproc)" --target "$@"
rm -rf .carry && mkdir -p .carry/bin .carry/lib
# Libraries every Linux system has, and the driver's own: never carried.
system='^(linux-vdso|libc\.|libm\.|libstdc\+\+|libgcc_s|ld-linux|libpthread|libdl\.|librt\.|libcuda\.)'
for t in "$@"; do
  exe=$(find build-device -type f -name "$t" -perm -u+x | head -n 1)
  [ -n "$exe" ] || { echo "no executable named $t in build-device/" >&2; exit 1; }
  cp "$exe" .carry/bin/
  ldd "$exe" | awk '$3 ~ /^\// {print $1, $3}' | while read -r name path; do
    [[ "$name" =~ $system ]] && continue
    cp -nL "$path" .carry/lib/
  done
done
size=$(du -sm .carry | cut -f1)
echo "device-bundle: .carry/ holds $(ls .carry/bin | wc -l) executables and $(ls .carry/lib | wc -l) libraries, ${size} MiB" >&2
if ((size > 60)); then echo "device-bundle: over the device tool's limit; carry fewer targets" >&2; exit 1; fi
