#!/usr/bin/env bash
# Tests 1 and 2 of the seed on a lent GPU machine (Figures 5.9-5.12): prediction, correction
# and belief fusion (each backend's own: Backend::fuse) of cpu-seq (the conventional sequential
# RBE), cpu-par, cuda-seed and cuda-resident, against the kernel size (grid 1000x1000, kernels
# 1..201) and the grid size (kernel 25, grids 100..1000 and 2000, 4000), and the CUDA backends'
# estimate and fusion tests. Bundle first, here:
#   scripts/device-bundle.sh -o .carry-sar bench_sar_parts test_rbe_estimate_gpu test_sar_fusion_gpu
# then on the GPU machine, with the bundle beside the repository, naming the commit it was built
# from (the device's copy of the tree does not know it):
#   COMMIT=$(git rev-parse --short HEAD) BUNDLE=.carry-sar bash benchmarks/sar/gpu.sh
#   (about 5 minutes; results in $OUT) and here: python3 benchmarks/sar/summarize_parts.py FOLDER.
set -uo pipefail
[ -n "${COMMIT:-}" ] || { echo "gpu.sh: name the commit the bundle was built from: COMMIT=\$(git rev-parse --short HEAD) BUNDLE=... bash benchmarks/sar/gpu.sh" >&2; exit 2; }
cd "$(dirname "$0")/../.."
bundle=${BUNDLE:-.carry-sar}
[ -x "$bundle/bin/bench_sar_parts" ] || { echo "no $bundle/bin/bench_sar_parts: run scripts/device-bundle.sh -o $bundle bench_sar_parts test_rbe_estimate_gpu first" >&2; exit 2; }
export LD_LIBRARY_PATH=$PWD/$bundle/lib:${LD_LIBRARY_PATH:-}
B=$bundle/bin/bench_sar_parts
O=${OUT:-gpu-out}
mkdir -p "$O"
all=cpu-seq,cpu-par,cuda-seed,cuda-resident
{ nvidia-smi --query-gpu=name,driver_version --format=csv; nproc; date -u; } > "$O/machine.txt" 2>&1
# The estimate of the CUDA backends against the float64 closed-form reference (docs/rbe.md).
if [ -x "$bundle/bin/test_rbe_estimate_gpu" ]; then
  timeout 60 "$bundle/bin/test_rbe_estimate_gpu" > "$O/test_rbe_estimate_gpu.txt" 2>&1
  echo "test_rbe_estimate_gpu: exit $?" | tee -a "$O/log.txt"
fi
# Belief fusion of the CUDA backends against the float64 reference (tests/sar/test_sar_fusion.cpp).
if [ -x "$bundle/bin/test_sar_fusion_gpu" ]; then
  timeout 60 "$bundle/bin/test_sar_fusion_gpu" > "$O/test_sar_fusion_gpu.txt" 2>&1
  echo "test_sar_fusion_gpu: exit $?" | tee -a "$O/log.txt"
fi
timeout 300 "$B" --test 1 --grid 1000 --kernels 1:201:20 --backends "$all" --steps 3 -o "$O/test1.csv" 2>> "$O/log.txt"
timeout 120 "$B" --test 2 --kernel 25 --grids 100:1000:100 --backends "$all" --steps 5 -o "$O/test2.csv" 2>> "$O/log.txt"
timeout 120 "$B" --test 2 --kernel 25 --grids 2000:4000:2000 --backends "$all" --steps 3 -o "$O/test2-large.csv" 2>> "$O/log.txt"
{
  echo "made by: COMMIT=$COMMIT BUNDLE=$bundle bash benchmarks/sar/gpu.sh"
  echo "commit: $COMMIT (named by the caller: the bundle's build)"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} > "$O/HOW.txt"
tail -n 5 "$O/log.txt"
