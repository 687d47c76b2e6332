#!/usr/bin/env bash
# The calibration run on this (CPU) machine, cpu-seq and cpu-par: a probe for start values,
# the training set (Test 1, Test 2 and a random training set drawn with seed 7) and the
# held-out set (random:50, the default seed), each in replicate rounds; then the fit and the
# held-out validation per backend. Run it on a quiet machine: timings of other jobs land in
# the samples. About 2 minutes on 2 cores.
#   bash benchmarks/calibrate/cpu.sh [OUT_DIR] [ROUNDS]     (default cpu-out, 3 rounds)
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${DTFLOP:-build/dtflop}
O=${1:-cpu-out}
R=${2:-3}
mkdir -p "$O"
log="$O/log.txt"
say() { echo "== $* ($(date -u +%H:%M:%S), load $(cut -d' ' -f1-3 /proc/loadavg))" | tee -a "$log"; }

say probe
$D probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
# Round by round over everything (round 1 of every sweep, then round 2, ...): a configuration's
# rounds are a whole pass apart (about 40 s), and the training and held-out sets share the
# machine's slow spells alike. `--rounds r` on a store holding rounds 1..r-1 measures round r.
for r in $(seq 1 "$R"); do
  for b in cpu-seq cpu-par; do
    for plan in seed-test1 seed-test2; do
      say "round $r: sweep $b $plan"
      $D sweep rbe --backend "$b" --plan "$plan" --rounds "$r" --store "$O/fit.jsonl" --quiet 2>&1 | tee -a "$log"
    done
    say "round $r: sweep $b random:50 --seed 7 (training)"
    $D sweep rbe --backend "$b" --plan random:50 --seed 7 --rounds "$r" --store "$O/fit.jsonl" --quiet 2>&1 | tee -a "$log"
    say "round $r: sweep $b random:50 (held out)"
    $D sweep rbe --backend "$b" --plan random:50 --rounds "$r" --store "$O/held.jsonl" --quiet 2>&1 | tee -a "$log"
  done
done
for b in cpu-seq cpu-par; do
  say "calibrate $b"
  $D calibrate --store "$O/fit.jsonl" --backend "$b" --machine "$O/probed.json" -o "$O/fitted-$b.json" \
    > "$O/calibrate-$b.txt" 2>&1 || { cat "$O/calibrate-$b.txt"; exit 1; }
  say "validate $b"
  $D validate --store "$O/held.jsonl" --backend "$b" --machine "$O/fitted-$b.json" > "$O/validate-$b.txt" 2>&1 || true
  grep -E "^total:|model variant" "$O/validate-$b.txt" | tee -a "$log"
  say "calibrate and validate $b, rounds combined by the fastest"
  $D calibrate --store "$O/fit.jsonl" --backend "$b" --machine "$O/probed.json" -o "$O/fitted-$b-fastest.json" \
    --rounds-combine fastest > "$O/calibrate-$b-fastest.txt" 2>&1 || { cat "$O/calibrate-$b-fastest.txt"; exit 1; }
  $D validate --store "$O/held.jsonl" --backend "$b" --machine "$O/fitted-$b-fastest.json" \
    > "$O/validate-$b-fastest.txt" 2>&1 || true
  grep -E "^total:" "$O/validate-$b-fastest.txt" | tee -a "$log"
done
say done
