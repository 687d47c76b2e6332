#!/usr/bin/env bash
# DCT calibration of the cuda backend on a lent GPU, in one device call (about 3 minutes).
#   Here:    scripts/device-bundle.sh -o .carry-gpu dtflop test_dct_workload test_dct_cuda \
#              test_workload_contract test_calibrate_gpu
#   Device:  [FIT=0] CARRY=.carry-gpu OUT=$OUT bash benchmarks/dct/device.sh [ROUNDS]   (carry [".carry-gpu"])
# The GPU tests first (counts a DCT run declares before its frames against what the frames did,
# and against what CUPTI saw), a quick probe for start values, then ROUNDS rounds (default 3) of
# the training set (seed-support, seed-points, image-sizes, random:60 drawn with seed 7) and the
# held-out set (random:50, the default seed: none of its configurations is in the training set);
# then calibrate and validate per host memory kind of the frames (a pageable upload is another
# bandwidth). The seed plans' frames are pinned, so the pageable fit has only the random plan's
# frames: random:60 gave 32 on 2026-11-29 (random:30 gave 15, too few for a 5-fold
# cross-validation of 13 parameters). Each sweep is resumable and bounded in time; what was
# measured lands in $OUT/dct/.
set -uo pipefail
cd "$(dirname "$0")/../.."
C=${CARRY:-.carry-gpu}
[ -x "$C/bin/dtflop" ] || { echo "no bundle in $C/; build it with scripts/device-bundle.sh -o $C" >&2; exit 2; }
export LD_LIBRARY_PATH=$PWD/$C/lib:${LD_LIBRARY_PATH:-}
B=$C/bin
O=${OUT:-dct-device-out}/dct
R=${1:-3}
mkdir -p "$O"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
for t in test_dct_workload test_workload_contract test_calibrate_gpu test_dct_cuda; do
  [ -x "$B/$t" ] || continue
  timeout 120 "$B/$t" > "$O/$t.log" 2>&1
  echo "$t rc=$?"
done
timeout 40 "$B/dtflop" probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
echo "probe rc=$?"
sweep() {  # LIMIT_S STORE ARGS...
  local limit=$1 store=$2
  shift 2
  timeout "$limit" "$B/dtflop" sweep "$@" dct --backend cuda --store "$O/$store" --quiet 2>&1 | tail -n 1
}
for r in $(seq 1 "$R"); do
  sweep 60 fit.jsonl --plan seed-support --rounds "$r"
  sweep 60 fit.jsonl --plan seed-points --rounds "$r"
  sweep 70 fit.jsonl --plan image-sizes --rounds "$r"
  sweep 200 fit.jsonl --seed 7 --plan random:60 --rounds "$r"
  sweep 150 held.jsonl --plan random:50 --rounds "$r"
done
# FIT=0 leaves the fits to another machine (they took over 90 s each on a lent H100 host on
# 2026-11-27, and device time is scarce): the commands below, run where the stores are fetched.
[ "${FIT:-1}" = 0 ] && { echo "FIT=0: fit with dtflop calibrate --store fit.jsonl --match host-memory=M --machine probed.json"; exit 0; }
for m in pinned pageable; do
  timeout 90 "$B/dtflop" calibrate --store "$O/fit.jsonl" --match "host-memory=$m" --machine "$O/probed.json" \
    -o "$O/fitted-cuda-$m.json" > "$O/calibrate-cuda-$m.txt" 2>&1
  echo "calibrate $m rc=$?"
  timeout 40 "$B/dtflop" validate --store "$O/held.jsonl" --match "host-memory=$m" --machine "$O/fitted-cuda-$m.json" \
    --by-plan > "$O/validate-cuda-$m.txt" 2>&1
  grep -E "^total|variant|^dt_" "$O/validate-cuda-$m.txt" | head -n 7
done
