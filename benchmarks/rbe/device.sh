#!/usr/bin/env bash
# On the GPU machine, from the repository root: GPU tests, the GPU benchmarks, the PyTorch peer
# in the same call, the comparison table (dtflop vs PyTorch vs floor), cpu-par vs OpenCV.
#   here:   scripts/device-bundle.sh test_rbe_gpu bench_rbe bench_rbe_cpu_ratio
#   there:  OUT=folder benchmarks/rbe/device.sh     (with the bundle .carry/ beside the repository)
#   FILTER=regex (bench_rbe filter, default: cuda)  OUT=folder for logs (default rbe-device-out)
#   BUNDLE=folder (default .carry: what scripts/device-bundle.sh made)
set -uo pipefail
bundle=${BUNDLE:-.carry}
export LD_LIBRARY_PATH=$PWD/$bundle/lib
out=${OUT:-rbe-device-out}
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm,clocks.mem,temperature.gpu,power.draw --format=csv
echo "== GPU tests =="
$bundle/bin/test_rbe_gpu --gtest_brief=1 2>&1 | tee "$out/test_rbe_gpu.log" | tail -40
echo "== bench_rbe (GPU) =="
$bundle/bin/bench_rbe --benchmark_filter="${FILTER:-cuda}" --benchmark_out="$out/bench.json" \
  --benchmark_out_format=json 2>&1 | tee "$out/bench.log" | grep -v "^-" | cut -c1-150
echo "== PyTorch peer =="
PYTHONUNBUFFERED=1 python3 benchmarks/rbe/peer_torch.py --out "$out/torch.json"
echo "== cpu-par vs cv::sepFilter2D, all threads =="
$bundle/bin/bench_rbe_cpu_ratio --threads "$(nproc)" --reps 20 --rounds 5
echo "== dtflop vs PyTorch vs floor =="
python3 benchmarks/rbe/peer_torch.py --table "$out/bench.json" "$out/torch.json" | tee "$out/table.txt"
