#!/usr/bin/env bash
# Tests 1 and 2 of the seed (Figures 5.9-5.12) on this machine's CPU: prediction, correction
# and belief fusion (each backend's own) per backend, against the kernel size (grid 500x500) and the grid size
# (kernel 25); the speedup is cpu-seq's time over the backend's.
#   benchmarks/sar/test12.sh [OUT]      (default results/sar/test12-cpu; a few minutes)
# The GPU half runs on a lent GPU machine from a bundle: benchmarks/sar/gpu.sh.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-results/sar/test12-cpu}
bench=${BENCH:-build/benchmarks/sar/bench_sar_parts}
[ -x "$bench" ] || { echo "test12: no $bench; build it (cmake --build build --target bench_sar_parts)" >&2; exit 2; }
mkdir -p "$out"
"$bench" --test 1 --grid 500 --kernels 1:101:10 --backends cpu-seq,cpu-par --steps 3 -o "$out/test1.csv"
"$bench" --test 2 --kernel 25 --grids 100:1000:100 --backends cpu-seq,cpu-par --steps 3 -o "$out/test2.csv"
"$bench" --test 2 --kernel 25 --grids 2000:4000:2000 --backends cpu-seq,cpu-par --steps 3 -o "$out/test2-large.csv"
{
  echo "made by: benchmarks/sar/test12.sh $out"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "machine: $(getconf _NPROCESSORS_ONLN) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} > "$out/HOW.txt"
python3 benchmarks/sar/summarize_parts.py "$out"
