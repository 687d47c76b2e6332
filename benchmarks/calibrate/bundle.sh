#!/usr/bin/env bash
# Builds what the H200 calibration run needs (dtflop and the GPU tests it runs first) for the GPU machine and
# gathers it, with the non-system shared libraries, into .carry-calib/ (excluded from git through
# .git/info/exclude). Same method as scripts/device-bundle.sh, in its own build folder and carry
# folder so that engineers bundling other targets at the same time do not overwrite it.
#   benchmarks/calibrate/bundle.sh        then run benchmarks/calibrate/h200.sh there
set -euo pipefail
cd "$(dirname "$0")/../.."
grep -qx '/.carry-calib/' .git/info/exclude 2>/dev/null || echo '/.carry-calib/' >> .git/info/exclude
cmake -S . -B build-calib-device -G Ninja -DCMAKE_BUILD_TYPE=Release -DDTFLOP_DEVICE_BUNDLE=ON \
      -DDTFLOP_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-calib-device -j "$(nproc)" --target dtflop test_calibrate_gpu test_rbe_gpu test_probes_gpu
rm -rf .carry-calib && mkdir -p .carry-calib/bin .carry-calib/lib
system='^(linux-vdso|libc\.|libm\.|libstdc\+\+|libgcc_s|ld-linux|libpthread|libdl\.|librt\.|libcuda\.)'
for exe in build-calib-device/dtflop build-calib-device/tests/calibrate/test_calibrate_gpu \
           build-calib-device/tests/workloads/rbe/test_rbe_gpu build-calib-device/tests/probes/test_probes_gpu; do
  cp "$exe" .carry-calib/bin/
  ldd "$exe" | awk '$3 ~ /^\// {print $1, $3}' | while read -r name path; do
    [[ "$name" =~ $system ]] && continue
    cp -nL "$path" .carry-calib/lib/
  done
done
echo "bundle: .carry-calib holds $(du -sm .carry-calib | cut -f1) MiB" >&2
