#!/usr/bin/env bash
# cuda-bands on several GPUs (docs/PERFORMANCE.md, "One grid over several GPUs"): the step of one
# grid (default 16000 x 16000, kernel 33, 1 GiB of float32 belief) on 1, 2 and 4 GPUs (those
# visible), one band per GPU over NCCL, and the same partitions on one GPU (the same-device
# transport); the speedup over one GPU; then random training and held-out sets of cuda-bands
# (fitted on one, validated on the other) so the model's multi-GPU step error and its peer and
# all-reduce terms can be reported. Run from a device bundle (scripts/device-bundle.sh -o FOLDER
# dtflop), with NCCL on the loader's path (the bundle never holds it):
#
#   export LD_LIBRARY_PATH=$PWD/.carry/lib:$(python3 -c 'import nvidia.nccl, os; print(os.path.join(nvidia.nccl.__path__[0], "lib"))')
#   [DTFLOP=.carry/bin/dtflop] [N=16000] [K=33] [STEPS=20] [REPS=5] [SETS=40] bash benchmarks/multigpu/scaling.sh OUT
#
# (SETS=0: the scaling table alone; an OUT/probed.json already there is used as it is.)
#
# Memory: per band q twice and l, 3 x 4 n_y n_x / G bytes on its GPU (3 GiB on one GPU at 16000^2),
# and ~10 GiB of host memory while the float64 problem is made.
# Writes OUT/probed.json (dtflop probe, its GPU probes: gpu-peer fills L_peer, B_peer, L_allreduce, B_allreduce
# where two GPUs are visible), OUT/run-P<p>-G<g>.json (dtflop run --json), OUT/scaling.txt, the
# plans OUT/train.json and OUT/held.json, the stores OUT/train.jsonl and OUT/held.jsonl,
# OUT/fitted.json (dtflop calibrate) and OUT/validate.txt (dtflop validate on the held-out set).
# Timing: --no-cupti, so a step's device time is the events on band 0's stream: CUPTI would add
# the kernels of every GPU and NCCL's own.
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${DTFLOP:-.carry/bin/dtflop}
N=${N:-16000}
K=${K:-33}
STEPS=${STEPS:-20}
REPS=${REPS:-5}
SETS=${SETS:-40}
[ $# -eq 1 ] || { echo "usage: $0 OUT (e.g. $0 \$OUT/multigpu)" >&2; exit 2; }
O=$1
mkdir -p "$O"
export NCCL_NVLS_ENABLE=${NCCL_NVLS_ENABLE:-0}  # NVLink multicast off unless the caller set it
log="$O/log.txt"
say() { echo "== $* ($(date -u +%H:%M:%S))" | tee -a "$log"; }
visible=$(nvidia-smi -L 2>/dev/null | wc -l)
[ "$visible" -ge 1 ] || { echo "scaling: no GPU visible" >&2; exit 1; }
counts=()
for g in 1 2 4; do [ "$g" -le "$visible" ] && counts+=("$g"); done
say "probe ($visible GPUs visible)"
# The GPU probes only: cuda-bands prices nothing the CPU probes give, and on a lent 64-thread
# host the whole probe took 6 minutes (2026-11-26).
[ -e "$O/probed.json" ] || "$D" probe --only gpu-transfers,gpu-memory,gpu-peer,gpu-fma,gpu-rows,gpu-tiles,gpu-atomics,gpu-launch \
  -o "$O/probed.json" > "$O/probe.txt" 2>&1

run() {  # partitions gpus
  local f="$O/run-P$1-G$2.json"
  [ -e "$f" ] || "$D" run rbe --backend cuda-bands --grid "${N}x${N}" --kernel "${K}x${K}" --partitions "$1" --gpus "$2" \
    --steps "$STEPS" --reps "$REPS" --warmup 1 --no-cupti --machine "$O/probed.json" --json -o "$f" >> "$log" 2>&1
}
say "scaling: ${N}x${N}, kernel ${K}"
for g in "${counts[@]}"; do run "$g" "$g"; done       # one band per GPU
for p in 2 4; do run "$p" 1; done                      # the partitions on one GPU
python3 - "$O" "${counts[@]}" <<'PY' | tee "$O/scaling.txt"
import json, sys, os
out, counts = sys.argv[1], [int(c) for c in sys.argv[2:]]
def load(p, g):
    with open(os.path.join(out, f"run-P{p}-G{g}.json")) as f:
        return json.load(f)
one = load(1, 1)["measured_per_step"]["total"]["median"]
print(f"{'placement':<26} {'step':>10} {'speedup':>8} {'predicted/measured':>19}")
rows = [(g, g) for g in counts] + [(2, 1), (4, 1)]
for p, g in rows:
    j = load(p, g)
    t = j["measured_per_step"]["total"]["median"]
    pm = j.get("predicted_over_measured")
    where = f"{p} bands on {g} GPU{'s' if g > 1 else ''}"
    print(f"{where:<26} {t * 1e3:>8.3f} ms {one / t:>7.2f}x {pm if pm is None else f'{pm:.3f}':>19}")
PY

# Random sets: grids n x n with n in [2000, 8000], kernels odd in [3, 65], on every placement
# above; the training set (seed 1) is fitted, the held-out one (seed 2) only validated. SETS=0
# stops after the scaling table.
[ "$SETS" -gt 0 ] || exit 0
say "random sets"
plan() {  # seed file
  python3 - "$1" "$SETS" "${counts[@]}" > "$2" <<'PY'
import json, random, sys
seed, n, counts = int(sys.argv[1]), int(sys.argv[2]), [int(c) for c in sys.argv[3:]]
rng = random.Random(seed)
places = [(g, g) for g in counts] + [(p, 1) for p in (2, 4)]
configs = []
for _ in range(n):
    side = rng.randint(2000, 8000)
    k = 2 * rng.randint(1, 32) + 1
    p, g = rng.choice(places)
    configs.append({"grid": [side, side], "kernel": [k, k], "partitions": p, "gpus": g})
print(json.dumps({"description": f"{n} random cuda-bands configurations (seed {seed}): n x n, n in [2000, 8000], "
                  f"kernel k x k, k odd in [3, 65], placements {places}", "configs": configs}))
PY
}
[ -e "$O/train.json" ] || plan 1 "$O/train.json"
[ -e "$O/held.json" ] || plan 2 "$O/held.json"
"$D" sweep rbe --backend cuda-bands --plan "$O/train.json" --store "$O/train.jsonl" --no-cupti --quiet 2>&1 | tee -a "$log"
"$D" sweep rbe --backend cuda-bands --plan "$O/held.json" --store "$O/held.jsonl" --no-cupti --quiet 2>&1 | tee -a "$log"
say "calibrate and validate"
# --accept-bounds: the halos travel while the inner rows are computed, so the fit prices them
# faster than the probe's NCCL send/recv alone (B_peer at its bound, 2026-11-24 on two H200s);
# calibrate.txt names every parameter at a bound.
"$D" calibrate --store "$O/train.jsonl" --machine "$O/probed.json" --accept-bounds -o "$O/fitted.json" > "$O/calibrate.txt" 2>&1 || true
"$D" validate --store "$O/held.jsonl" --machine "$O/fitted.json" --backend cuda-bands > "$O/validate.txt" 2>&1 || true
# The peer and all-reduce terms of the 16000^2 step on the fitted profile.
for g in "${counts[@]}"; do
  "$D" predict rbe --backend cuda-bands --grid "${N}x${N}" --kernel "${K}x${K}" --partitions "$g" --gpus "$g" \
    --machine "$O/fitted.json" > "$O/predict-P$g-G$g.txt" 2>&1 || true
done
grep -H "^total:" "$O/validate.txt" || true
grep -H "dt_peer\|dt_allreduce" "$O"/predict-*.txt || true
