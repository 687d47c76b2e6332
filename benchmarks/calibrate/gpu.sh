#!/usr/bin/env bash
# The calibration run on a lent GPU machine (H200 or H100): GPU tests, a quick probe for start
# values, then the RBE sweeps, in replicate rounds (docs/calibration.md, "Rounds"). ROUNDS=n
# sets the rounds of `all` (default 5; 3 fit a 10-minute device call). Bundle first, here:
#   scripts/device-bundle.sh dtflop test_calibrate_gpu test_rbe_gpu test_probes_gpu
# then, on the GPU machine with the bundle (.carry/, or BUNDLE=folder) beside the repository:
#   bash benchmarks/calibrate/gpu.sh all    everything below in one device call (5 rounds:
#                                            about 400 s; the time limits below bound a stuck
#                                            sweep, they do not add up to under 10 minutes), the
#                                            training and held-out sets measured round by round
#                                            in turn (round 1 of both, round 2 of both, ...), so
#                                            that a drift of the host's speed falls on both alike.
#                                            Five rounds, because one round of a configuration
#                                            differs from another by 5-10% (p90) on this machine
#                                            (copies most), and the median of three still moved
#                                            single held-out errors by 2-3 points; Test 1 (200
#                                            kernels on one grid, dense already) takes two
#   bash benchmarks/calibrate/gpu.sh resident   both sets for cuda-resident alone, with a probe
#                                            and the GPU tests (about 2 minutes)
#   bash benchmarks/calibrate/gpu.sh seed       both sets for cuda-seed alone, pageable and pinned,
#                                            ROUNDS rounds (default 3), with a probe and the GPU
#                                            tests
# Each sweep is resumable and bounded in time, so a slow one cannot take the whole lease;
# whatever was measured comes back in $OUT (or ./gpu-out). Fitting and validation run
# afterwards on the developer's machine from the stores (docs/PERFORMANCE.md; the stores of
# the recorded runs are in results/rbe-calibration/).
set -uo pipefail
cd "$(dirname "$0")/../.."
bundle=${BUNDLE:-.carry}
[ -x "$bundle/bin/dtflop" ] || { echo "no $bundle/bin/dtflop: run scripts/device-bundle.sh dtflop test_calibrate_gpu test_rbe_gpu test_probes_gpu first, and copy $bundle/ beside the repository" >&2; exit 2; }
export LD_LIBRARY_PATH=$PWD/$bundle/lib:${LD_LIBRARY_PATH:-}
B=$bundle/bin
O=${OUT:-gpu-out}
part=${1:-}
[[ "$part" == all || "$part" == resident || "$part" == seed ]] || { echo "usage: $0 all|resident|seed" >&2; exit 2; }
mkdir -p "$O"
log="$O/log-$part.txt"
say() { echo "== $* ($(date -u +%H:%M:%S))" | tee -a "$log"; }
sweep() {  # sweep LIMIT_S STORE [--seed S] ARGS...
  # --seed S is the random plan's seed.
  local limit=$1 store=$2 plan_seed=()
  shift 2
  if [[ "${1:-}" == --seed ]]; then plan_seed=(--seed "$2"); shift 2; fi
  say "sweep ${plan_seed[*]:+${plan_seed[*]} }rbe $* -> $store"
  timeout "$limit" $B/dtflop sweep "${plan_seed[@]}" rbe --store "$O/$store" --quiet "$@" 2>&1 | tee -a "$log"
}

say machine
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm,clocks.mem,temperature.gpu,power.draw \
  --format=csv 2>&1 | tee -a "$log"
nproc | tee -a "$log"

probe_quick() {  # start values for the fit (and the identity the stores are checked against)
  say probe
  timeout 60 $B/dtflop probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
  tail -n 40 "$O/probe.txt" >> "$log"
}

gpu_tests() {
  say "GPU tests"
  for t in test_calibrate_gpu test_rbe_gpu test_probes_gpu; do
    timeout 60 $B/$t > "$O/$t.txt" 2>&1
    echo "$t: exit $?, $(grep -cE '^\[       OK \]' "$O/$t.txt") passed, $(grep -cE '^\[  FAILED  \]' "$O/$t.txt") failed lines" | tee -a "$log"
    grep -E "Failure|Expected|Which is|Value of|Actual" "$O/$t.txt" | head -n 20 | tee -a "$log"
  done
  # cuda-resident's other tile copy (16-byte cp.async, where the tensor memory accelerator is not
  # there or is switched off), on the same cases.
  t=test_rbe_gpu_no_tma
  DTFLOP_RBE_NO_TMA=1 timeout 60 $B/test_rbe_gpu --gtest_filter='RbeCudaResident.*' > "$O/$t.txt" 2>&1
  echo "$t: exit $?, $(grep -cE '^\[       OK \]' "$O/$t.txt") passed, $(grep -cE '^\[  FAILED  \]' "$O/$t.txt") failed lines" | tee -a "$log"
  grep -E "Failure|Expected|Which is|Value of|Actual" "$O/$t.txt" | head -n 20 | tee -a "$log"
}

if [[ "$part" == all ]]; then
  probe_quick
  gpu_tests
  # Rounds are resumable: `--rounds r` on a store holding rounds 1..r-1 measures round r only.
  for ((r = 1; r <= ${ROUNDS:-5}; ++r)); do
    for setup in "--backend cuda-seed" "--backend cuda-seed --host-memory pinned" "--backend cuda-resident"; do
      # shellcheck disable=SC2086
      sweep 60 fit.jsonl $setup --plan seed-test2 --rounds $r
      # shellcheck disable=SC2086
      sweep 60 fit.jsonl --seed 7 $setup --plan random:50 --rounds $r
      # shellcheck disable=SC2086
      sweep 60 held.jsonl $setup --plan random:50 --rounds $r
    done
    if (( r <= 2 )); then
      sweep 120 fit.jsonl --backend cuda-seed --plan seed-test1 --rounds $r
      sweep 60 fit.jsonl --backend cuda-resident --plan seed-test1 --rounds $r
    fi
  done
elif [[ "$part" == resident ]]; then
  probe_quick
  gpu_tests
  sweep 60 fit.jsonl --backend cuda-resident --plan seed-test2 --rounds 3
  sweep 60 fit.jsonl --seed 7 --backend cuda-resident --plan random:50 --rounds 3
  sweep 90 fit.jsonl --backend cuda-resident --plan seed-test1 --rounds 2
  sweep 60 held.jsonl --backend cuda-resident --plan random:50 --rounds 3
elif [[ "$part" == seed ]]; then
  probe_quick
  gpu_tests
  for ((r = 1; r <= ${ROUNDS:-3}; ++r)); do
    for memory in pageable pinned; do
      sweep 60 fit.jsonl --backend cuda-seed --host-memory $memory --plan seed-test2 --rounds $r
      sweep 60 fit.jsonl --seed 7 --backend cuda-seed --host-memory $memory --plan random:50 --rounds $r
      sweep 60 held.jsonl --backend cuda-seed --host-memory $memory --plan random:50 --rounds $r
    done
    if (( r <= 2 )); then sweep 120 fit.jsonl --backend cuda-seed --plan seed-test1 --rounds $r; fi
  done
fi
say done
wc -l "$O"/*.jsonl | tee -a "$log"
