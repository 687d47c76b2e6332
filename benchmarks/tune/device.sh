#!/usr/bin/env bash
# The tuner's benchmark on one machine (docs/PERFORMANCE.md, "Tuning"): every valid configuration
# of a scenario measured into a store, then the strategies replayed on the stored times (model and
# random, 10 seeds, budgets 5/10/20/50), the BoTorch peer on the same times where BoTorch is
# installed, and the model strategy's own tuning at its default budget of 20.
#   benchmarks/tune/device.sh SCENARIO MACHINE OUTDIR [dtflop tune options...]
# e.g. on the lent H100 with a bundle (scripts/device-bundle.sh dtflop) in BUNDLE=.carry:
#   bash benchmarks/tune/device.sh tune/scenarios/sar-drift-gpu.yaml docs/examples/h100.json $OUT/h100 \
#        --calibration results/portability/calibrations/h100-cuda-resident.cal.json ...
# the DCT space on a GPU (cuda alone: support, weight, threshold, 12 block layouts; ~470 valid):
#   bash benchmarks/tune/device.sh tune/scenarios/open-hole-plate-gpu.yaml docs/examples/h100.json $OUT/h100-dct \
#        --no-cupti --reps 5
# PEER=0 leaves the peer out (run it later on the space.csv, e.g. in a call of its own);
# and here, on the 2-core machine (BUNDLE=build, where build/dtflop is):
#   BUNDLE=build bash benchmarks/tune/device.sh tune/scenarios/sar-drift-cpu.yaml docs/examples/vm-2vcpu.json out/cpu
set -uo pipefail
cd "$(dirname "$0")/../.."
(($# >= 3)) || { echo "usage: $0 SCENARIO MACHINE OUTDIR [dtflop tune options...]" >&2; exit 2; }
scenario=$1 machine=$2 out=$3
shift 3
bundle=${BUNDLE:-.carry}
if [ -x "$bundle/bin/dtflop" ]; then
  export LD_LIBRARY_PATH=$PWD/$bundle/lib:${LD_LIBRARY_PATH:-}
  dtflop=$bundle/bin/dtflop
elif [ -x "$bundle/dtflop" ]; then
  dtflop=$bundle/dtflop
else
  echo "no dtflop in $bundle/bin or $bundle: build it (or scripts/device-bundle.sh dtflop) first" >&2
  exit 2
fi
mkdir -p "$out"
common=(--scenario "$scenario" --machine "$machine" --store "$out/store.jsonl" "$@")
echo "== exhaustive, then replay" >&2
"$dtflop" tune "${common[@]}" --replay 5,10,20,50 --replay-seeds 10 --space-csv "$out/space.csv" \
  -o "$out/replay.json" >"$out/replay.txt" || echo "tune --replay exited $?" >&2
echo "== model at budget 20 (from the store: nothing is measured again)" >&2
"$dtflop" tune "${common[@]}" --strategy model --budget 20 -o "$out/model.json" >"$out/model.txt" ||
  echo "tune --strategy model exited $?" >&2
if [ "${PEER:-1}" = 0 ]; then
  echo "(PEER=0: no peer run)" >&2
elif python3 -c "import botorch" 2>/dev/null; then
  echo "== BoTorch peer" >&2
  python3 benchmarks/tune/peer_botorch.py "$out/space.csv" --budgets 5,10,20,50 --seeds 10 >"$out/botorch.json" ||
    echo "peer_botorch exited $?" >&2
else
  echo "(BoTorch not installed here: no peer run)" >&2
fi
