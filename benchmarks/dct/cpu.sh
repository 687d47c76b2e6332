#!/usr/bin/env bash
# DCT calibration on this (CPU) machine, cpu-seq and cpu-par: a probe for start values, the
# training set (seed-support, seed-points, image-sizes, image-kinds and random:30 drawn with seed 7) and the
# held-out set (random:50, the default seed: none of its configurations is in the training
# set), measured round by round; then the fit and the held-out validation per backend, with the
# rounds combined by their median and by the fastest (docs/calibration.md, "Rounds").
# Run it on a quiet machine: other jobs' time lands in the samples.
#   bash benchmarks/dct/cpu.sh [OUT_DIR] [ROUNDS]     (default results/dct-calibration/cpu-<date>, 3)
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${DTFLOP:-build/dtflop}
O=${1:-results/dct-calibration/cpu-$(date -u +%Y-%m-%d)}
R=${2:-3}
mkdir -p "$O"
log="$O/log.txt"
say() { echo "== $* ($(date -u +%H:%M:%S), load $(cut -d' ' -f1-3 /proc/loadavg))" | tee -a "$log"; }
sweep_round() {  # backend round
  local b=$1 r=$2
  for plan in seed-support seed-points image-sizes image-kinds; do
    $D sweep dct --backend "$b" --plan "$plan" --rounds "$r" --store "$O/fit.jsonl" --quiet 2>&1 | tee -a "$log"
  done
  $D sweep --seed 7 dct --backend "$b" --plan random:30 --rounds "$r" --store "$O/fit.jsonl" --quiet 2>&1 | tee -a "$log"
  $D sweep dct --backend "$b" --plan random:50 --rounds "$r" --store "$O/held.jsonl" --quiet 2>&1 | tee -a "$log"
}
say probe
$D probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
for r in $(seq 1 "$R"); do
  for b in cpu-par cpu-seq; do say "round $r: $b"; sweep_round "$b" "$r"; done
done
for b in cpu-seq cpu-par; do
  for c in median fastest; do
    say "calibrate and validate $b, rounds combined by the $c"
    # A fit whose parameter ends on its physical bound is written only with --accept-bounds: say
    # so in the log and keep it (its table flags the parameter BOUND), so that the validation runs.
    if ! $D calibrate --store "$O/fit.jsonl" --backend "$b" --machine "$O/probed.json" -o "$O/fitted-$b-$c.json" \
      --rounds-combine "$c" > "$O/calibrate-$b-$c.txt" 2>&1; then
      grep -E "^dtflop: " "$O/calibrate-$b-$c.txt" | tee -a "$log"
      grep -q "reached its physical bound\|reached their physical bound" "$O/calibrate-$b-$c.txt" || exit 1
      say "refit $b ($c) with --accept-bounds"
      $D calibrate --store "$O/fit.jsonl" --backend "$b" --machine "$O/probed.json" -o "$O/fitted-$b-$c.json" \
        --rounds-combine "$c" --accept-bounds > "$O/calibrate-$b-$c.txt" 2>&1 || { cat "$O/calibrate-$b-$c.txt"; exit 1; }
    fi
    $D validate --store "$O/held.jsonl" --backend "$b" --machine "$O/fitted-$b-$c.json" --rounds-combine "$c" \
      --by-plan > "$O/validate-$b-$c.txt" 2>&1 || true
    grep -E "^total:|model variant" "$O/validate-$b-$c.txt" | tee -a "$log"
  done
done
say done
