#!/usr/bin/env bash
# Builds the RBE executables for the lent GPU machine into build-rbe-device/ (or $BUILD) and
# gathers them, with the non-system shared libraries they need, into $BUILD/carry/ (git-ignored;
# pass it as `carry`). The same recipe as scripts/device-bundle.sh, in a folder of its own so
# that it never clobbers another bundle being built at the same time.
#   [BUILD=dir] benchmarks/rbe/bundle.sh [TARGET...]   default: test_rbe_gpu bench_rbe bench_rbe_cpu_ratio
set -euo pipefail
cd "$(dirname "$0")/../.."
targets=("$@")
((${#targets[@]})) || targets=(test_rbe_gpu bench_rbe bench_rbe_cpu_ratio)
build=${BUILD:-build-rbe-device}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDTFLOP_DEVICE_BUNDLE=ON \
      -DCMAKE_CUDA20_STANDARD_COMPILE_OPTION=-std=c++20 -DCMAKE_CUDA20_EXTENSION_COMPILE_OPTION=-std=c++20 >/dev/null
cmake --build "$build" -j "$(nproc)" --target "${targets[@]}"
carry=$build/carry
rm -rf "$carry" && mkdir -p "$carry/bin" "$carry/lib"
system='^(linux-vdso|libc\.|libm\.|libstdc\+\+|libgcc_s|ld-linux|libpthread|libdl\.|librt\.|libcuda\.)'
for t in "${targets[@]}"; do
  exe=$(find "$build" -path "$carry" -prune -o -type f -name "$t" -perm -u+x -print | head -n 1)
  [ -n "$exe" ] || { echo "no executable named $t in $build/" >&2; exit 1; }
  cp "$exe" "$carry/bin/"
  ldd "$exe" | awk '$3 ~ /^\// {print $1, $3}' | while read -r name path; do
    [[ "$name" =~ $system ]] && continue
    cp -nL "$path" "$carry/lib/"
  done
done
size=$(du -sm "$carry" | cut -f1)
echo "bundle: $carry holds $(ls "$carry/bin" | wc -l) executables and $(ls "$carry/lib" | wc -l) libraries, ${size} MiB" >&2
if ((size > 60)); then echo "bundle: over the device tool's limit; carry fewer targets" >&2; exit 1; fi
