#!/usr/bin/env bash
# On the GPU machine, the short version of device.sh for cuda-resident's three speed targets:
# GPU tests (twice: also with DTFLOP_RBE_NO_TMA, so that the cp.async tile copies are tested
# too), bench_rbe at 1000x1000 k33, 1000x1000 k201 and 4000x4000 k33 (default layout and the
# layout sweep), the PyTorch peer, the comparison table.
#   here:   scripts/device-bundle.sh test_rbe_gpu bench_rbe
#   there:  OUT=folder benchmarks/rbe/device_targets.sh   (bundle in .carry/, or BUNDLE=folder;
#           logs in OUT, default rbe-device-out)
# ALT=1 adds the defaults with cp.async tile copies (DTFLOP_RBE_NO_TMA, see docs/rbe.md);
# NO_PEER=1 leaves the PyTorch peer out.
set -uo pipefail
bundle=${BUNDLE:-.carry}
export LD_LIBRARY_PATH=$PWD/$bundle/lib
out=${OUT:-rbe-device-out}
mkdir -p "$out"
targets='^rbe/cuda-resident/(1000x1000/k(33|201)|4000x4000/k33)/'
defaults='^rbe/cuda-resident/(1000x1000/k(33|201)|4000x4000/k33)/(32x8x16|layout-(32x16x8|64x8x8|64x4x16|32x4x16))/'
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm,clocks.mem,temperature.gpu,power.draw --format=csv
echo "== GPU tests =="
timeout 120 $bundle/bin/test_rbe_gpu --gtest_brief=1 2>&1 | tee "$out/test_rbe_gpu.log" | tail -15
echo "== GPU tests, cp.async tile copies =="
DTFLOP_RBE_NO_TMA=1 timeout 120 $bundle/bin/test_rbe_gpu --gtest_brief=1 2>&1 |
  tee "$out/test_rbe_gpu_alt.log" | tail -15
bench() {  # name filter [env...]
  local name=$1 filter=$2; shift 2
  env "$@" timeout 240 $bundle/bin/bench_rbe --benchmark_filter="$filter" --benchmark_out="$out/$name.json" \
    --benchmark_out_format=json 2>/dev/null | grep "^rbe/" | awk -v n="$name" '{print n, $1, $2, $3}'
}
echo "== bench_rbe: targets =="
bench bench "$targets"
if [ -n "${ALT:-}" ]; then
  echo "== bench_rbe: defaults, cp.async tile copies =="
  bench bench_notma "$defaults" DTFLOP_RBE_NO_TMA=1
fi
if [ -z "${NO_PEER:-}" ]; then
  echo "== PyTorch peer =="
  PYTHONUNBUFFERED=1 timeout 120 python3 benchmarks/rbe/peer_torch.py --out "$out/torch.json"
  echo "== dtflop vs PyTorch vs floor =="
  python3 benchmarks/rbe/peer_torch.py --table "$out/bench.json" "$out/torch.json" | tee "$out/table.txt"
fi
