#!/usr/bin/env bash
# DCT calibration of the cuda backend on a lent GPU, in one device call.
#   Here:    scripts/device-bundle.sh dtflop test_dct_workload && rm -rf .carry-dct2 && mv .carry .carry-dct2
#   Device:  bash benchmarks/dct/device.sh [ROUNDS]      (carry [".carry-dct2"]; results in $OUT)
# The GPU cases of test_dct_workload first (the counts a Run declares before its frames against
# what the frames did), a quick probe for start values, then the training set (seed-support,
# seed-points, image-sizes, random:30 --seed 7) and the held-out set (random:50: pinned and
# pageable frames, 8- and 16-bit, MLS and FE), round by round; then calibrate and validate per
# host memory kind (a pageable upload is staged by the driver: another bandwidth). Each sweep is
# resumable and bounded in time; whatever was measured comes back in $OUT.
set -uo pipefail
cd "$(dirname "$0")/../.."
C=${CARRY:-.carry-dct2}
[ -x "$C/bin/dtflop" ] || { echo "no bundle in $C/; build it with scripts/device-bundle.sh and move .carry there" >&2; exit 2; }
export LD_LIBRARY_PATH=$PWD/$C/lib:${LD_LIBRARY_PATH:-}
B=$C/bin
O=${OUT:-dct-device-out}
R=${1:-2}
mkdir -p "$O"
log="$O/log.txt"
say() { echo "== $* ($(date -u +%H:%M:%S))" | tee -a "$log"; }
sweep() {  # LIMIT_S STORE ARGS...
  local limit=$1 store=$2
  shift 2
  timeout "$limit" $B/dtflop sweep dct --backend cuda --store "$O/$store" --quiet "$@" 2>&1 | tee -a "$log"
}
say machine
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv 2>&1 | tee -a "$log"
say "GPU tests"
timeout 120 $B/test_dct_workload 2>&1 | tail -n 25 | tee -a "$log"
say probe
timeout 60 $B/dtflop probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
for r in $(seq 1 "$R"); do
  say "round $r"
  for plan in seed-support seed-points image-sizes; do sweep 90 fit.jsonl --plan "$plan" --rounds "$r"; done
  sweep 120 fit.jsonl --plan random:30 --seed 7 --rounds "$r"
  sweep 150 held.jsonl --plan random:50 --rounds "$r"
done
for m in pinned pageable; do
  say "calibrate and validate cuda, $m frames"
  timeout 60 $B/dtflop calibrate --store "$O/fit.jsonl" --backend cuda --match "/host-memory=$m/" \
    --machine "$O/probed.json" -o "$O/fitted-cuda-$m.json" > "$O/calibrate-cuda-$m.txt" 2>&1
  timeout 60 $B/dtflop validate --store "$O/held.jsonl" --backend cuda --match "/host-memory=$m/" \
    --machine "$O/fitted-cuda-$m.json" --by-plan > "$O/validate-cuda-$m.txt" 2>&1
  grep -E "^total:|model variant" "$O/validate-cuda-$m.txt" | tee -a "$log"
done
say done
