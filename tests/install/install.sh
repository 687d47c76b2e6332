#!/usr/bin/env bash
# install.sh BUILD SOURCE WORK GENERATOR: `cmake --install` BUILD into WORK/prefix, configure and
# build SOURCE/examples/predict against it (find_package(dtflop)), and check that the example
# predicts with the installed H200 profile and that the installed dtflop runs.
set -euo pipefail
build=$1 src=$2 work=$3 gen=$4
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
test -x "$work/prefix/bin/dtflop"
test -f "$work/prefix/include/dtflop/model/predict.hpp"
test -f "$work/prefix/lib/cmake/dtflop/dtflopConfig.cmake"
cmake -S "$src/examples/predict" -B "$work/example" -G "$gen" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$work/prefix" >"$work/configure.log"
cmake --build "$work/example" >"$work/build.log"
out=$("$work/example/predict_example" "$work/prefix/share/dtflop/examples/h200.json" 1048576)
echo "$out"
# The H200 profile: 4 MiB each way over pinned copies (~55 GB/s) is ~80 us each: the total is
# tens of microseconds to a millisecond, whatever the variant.
total=$(sed -n 's/.*total \([0-9.e+-]*\) s.*/\1/p' <<<"$out")
awk -v t="$total" 'BEGIN { exit !(t > 5e-5 && t < 1e-3) }' || { echo "unexpected total: $total s" >&2; exit 1; }
grep -q "NVIDIA H200" <<<"$out"
"$work/prefix/bin/dtflop" --version | grep -q '^dtflop '
"$work/prefix/bin/dtflop" predict rbe --backend cuda-resident --machine "$work/prefix/share/dtflop/examples/h200.json" >/dev/null
rm -rf "$work"
