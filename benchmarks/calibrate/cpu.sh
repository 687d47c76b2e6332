#!/usr/bin/env bash
# The calibration run on this (CPU) machine, cpu-seq and cpu-par: a probe for start values,
# the training set (Test 1, Test 2 and a random training set drawn with seed 7) and the
# held-out set (random:50, the default seed), each in replicate rounds; then the fit and the
# held-out validation per backend, with rounds combined by their median and by the fastest.
# Run it on a quiet machine: timings of other jobs land in the samples. About 10 minutes on
# 2 cores with the default rounds.
#   bash benchmarks/calibrate/cpu.sh [OUT_DIR] [ROUNDS_SEQ] [ROUNDS_PAR]
#   (default cpu-out, 8 rounds of cpu-seq, 30 of cpu-par)
# Why so many rounds: on a shared virtual machine each core runs at one of two or more speeds
# for seconds at a time (another tenant on the physical core); a round's samples all fall in
# one such spell. cpu-par needs both cores fast at once, so it needs more rounds than cpu-seq
# before its fastest round is the machine's undisturbed speed (docs/PERFORMANCE.md).
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${DTFLOP:-build/dtflop}
O=${1:-cpu-out}
R_SEQ=${2:-8}
R_PAR=${3:-30}
mkdir -p "$O"
log="$O/log.txt"
say() { echo "== $* ($(date -u +%H:%M:%S), load $(cut -d' ' -f1-3 /proc/loadavg))" | tee -a "$log"; }

sweep_round() {  # backend round
  local b=$1 r=$2
  for plan in seed-test1 seed-test2; do
    $D sweep rbe --backend "$b" --plan "$plan" --rounds "$r" --store "$O/fit.jsonl" --quiet 2>&1 | tee -a "$log"
  done
  $D sweep --seed 7 rbe --backend "$b" --plan random:50 --rounds "$r" --store "$O/fit.jsonl" --quiet 2>&1 | tee -a "$log"
  $D sweep rbe --backend "$b" --plan random:50 --rounds "$r" --store "$O/held.jsonl" --quiet 2>&1 | tee -a "$log"
}

say probe
$D probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
# Round by round over everything (round 1 of every sweep, then round 2, ...): a configuration's
# rounds are a whole pass apart, and the training and held-out sets share the machine's slow
# spells alike. `--rounds r` on a store holding rounds 1..r-1 measures round r. cpu-seq's rounds
# are spread evenly among cpu-par's.
R_MAX=$(( R_SEQ > R_PAR ? R_SEQ : R_PAR ))
seq_done=0
for r in $(seq 1 "$R_MAX"); do
  if [ "$r" -le "$R_PAR" ]; then say "round $r: cpu-par"; sweep_round cpu-par "$r"; fi
  # cpu-seq round k after cpu-par round ceil(k R_MAX / R_SEQ).
  while [ "$seq_done" -lt "$R_SEQ" ] && [ $(( (seq_done + 1) * R_MAX )) -le $(( r * R_SEQ )) ]; do
    seq_done=$((seq_done + 1))
    say "round $seq_done: cpu-seq"
    sweep_round cpu-seq "$seq_done"
  done
done
for b in cpu-seq cpu-par; do
  for c in median fastest; do
    say "calibrate and validate $b, rounds combined by the $c"
    $D calibrate --store "$O/fit.jsonl" --backend "$b" --machine "$O/probed.json" -o "$O/fitted-$b-$c.json" \
      --rounds-combine "$c" > "$O/calibrate-$b-$c.txt" 2>&1 || { cat "$O/calibrate-$b-$c.txt"; exit 1; }
    $D validate --store "$O/held.jsonl" --backend "$b" --machine "$O/fitted-$b-$c.json" --rounds-combine "$c" \
      > "$O/validate-$b-$c.txt" 2>&1 || true
    grep -E "^total:|model variant" "$O/validate-$b-$c.txt" | tee -a "$log"
  done
done
say done
