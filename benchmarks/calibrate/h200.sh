#!/usr/bin/env bash
# The calibration run on the lent H200 (one device call): CUPTI checks, a quick probe for start
# values, then the sweeps of the seed's Test 1 and Test 2 and 50 random held-out configurations
# for cuda-seed (pageable host memory, the seed's setting; Test 2 and held-out also pinned) and
# cuda-resident. Each sweep is resumable and bounded in time, so a slow one cannot take the
# whole lease; whatever was measured comes back. Fitting and validation run afterwards on the
# developer's machine from the stores (docs/PERFORMANCE.md, "Calibration and validation").
#   device:  bash benchmarks/calibrate/h200.sh        (writes to $OUT, or ./h200-out)
set -uo pipefail
cd "$(dirname "$0")/../.."
export LD_LIBRARY_PATH=$PWD/.carry-calib/lib:${LD_LIBRARY_PATH:-}
B=.carry-calib/bin
O=${OUT:-h200-out}
mkdir -p "$O"
log="$O/log.txt"
say() { echo "== $* ($(date -u +%H:%M:%S))" | tee -a "$log"; }

say machine
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm,clocks.mem,temperature.gpu,power.draw \
  --format=csv 2>&1 | tee -a "$log"
nproc | tee -a "$log"
say "GPU tests (CUPTI)"
timeout 45 $B/test_calibrate_gpu > "$O/gpu-tests.txt" 2>&1
grep -E "^\[  |Failure|Expected|Which is|Value of|Actual" "$O/gpu-tests.txt" | tail -n 30 | tee -a "$log"
say probe
timeout 60 $B/dtflop probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
tail -n 40 "$O/probe.txt" >> "$log"

sweep() {  # sweep LIMIT_S STORE ARGS...
  local limit=$1 store=$2
  shift 2
  say "sweep $* -> $store"
  timeout "$limit" $B/dtflop sweep rbe --store "$O/$store" --quiet "$@" 2>&1 | tee -a "$log"
}
sweep 140 fit.jsonl  --backend cuda-seed --plan seed-test1
sweep 30  fit.jsonl  --backend cuda-seed --plan seed-test2
sweep 40  fit.jsonl  --backend cuda-resident --plan seed-test1
sweep 20  fit.jsonl  --backend cuda-resident --plan seed-test2
sweep 20  fit.jsonl  --backend cuda-seed --memory pinned --plan seed-test2
sweep 40  held.jsonl --backend cuda-seed --plan random:50
sweep 20  held.jsonl --backend cuda-resident --plan random:50
sweep 20  held.jsonl --backend cuda-seed --memory pinned --plan random:50
say done
wc -l "$O"/*.jsonl | tee -a "$log"
