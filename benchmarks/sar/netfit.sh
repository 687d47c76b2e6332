#!/usr/bin/env bash
# The network term (L_net, B_net) fitted from the team's own MPI exchanges and checked held out:
# the net-mpi probe, then exchange sweeps of a 3-process team, one store fitted and one held out,
# taken in alternating rounds (fit, held, fit, held, ...) so that both see the machine's load
# alike (a shared machine's load drifts: sweeps taken one after the other differed by 2x), then
# dtflop calibrate (latency variant: the seed variant has no latency term) and dtflop validate.
# Beside it, the same sweep with 2 processes (one per core on a 2-core machine: what the
# ping-pong probe measures), fitted on its own: the gap between the two is the third process.
#   benchmarks/sar/netfit.sh [OUT]     (default results/sar/net-fit; under a minute)
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-results/sar/net-fit}
rounds=${ROUNDS:-5}
dtflop=${DTFLOP:-build/dtflop}
[ -x "$dtflop" ] || { echo "netfit: no $dtflop; build it (cmake --build build --target dtflop)" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] && export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mkdir -p "$out"
rm -f "$out/fit.jsonl" "$out/held.jsonl" "$out/fit2.jsonl" "$out"/sweep-*.txt
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
sweep() {  # PROCESSES STORE LOG ROUND
  mpirun --oversubscribe --bind-to none -n "$1" env OMP_NUM_THREADS=1 "$dtflop" sar --scenario sar/scenarios/table-5.5.yaml \
    --exchange-sweep --repetitions 5 --round "$4" --store "$2" 2>> "$3"
}
"$dtflop" probe --only net-mpi -o "$out/probed.json" > "$out/probe.txt" 2>&1
for r in $(seq 1 "$rounds"); do
  echo "round $r ($(cut -d' ' -f1-3 /proc/loadavg))" | tee -a "$out/sweep-fit.txt" "$out/sweep-held.txt" \
    "$out/sweep-fit2.txt" >/dev/null
  sweep 3 "$out/fit.jsonl" "$out/sweep-fit.txt" "$r"
  sweep 3 "$out/held.jsonl" "$out/sweep-held.txt" "$r"
  sweep 2 "$out/fit2.jsonl" "$out/sweep-fit2.txt" "$r"
done
"$dtflop" calibrate --store "$out/fit.jsonl" --machine "$out/probed.json" --variant latency --accept-bounds \
  -o "$out/fitted.json" > "$out/calibrate.txt" 2>&1
"$dtflop" validate --store "$out/held.jsonl" --machine "$out/fitted.json" > "$out/validate.txt" 2>&1 || true
"$dtflop" calibrate --store "$out/fit2.jsonl" --machine "$out/probed.json" --variant latency --accept-bounds \
  -o "$out/fitted2.json" > "$out/calibrate2.txt" 2>&1 || true
{
  echo "made by: benchmarks/sar/netfit.sh $out   (ROUNDS=$rounds)"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "machine: $(getconf _NPROCESSORS_ONLN) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "load average (1, 5, 15 min) before: $load_before; after: $(cut -d' ' -f1-3 /proc/loadavg)"
} > "$out/HOW.txt"
grep -E "^(L_net|B_net) " "$out/calibrate.txt" "$out/calibrate2.txt" || true
grep -E "^total" "$out/validate.txt" || true
