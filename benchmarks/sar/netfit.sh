#!/usr/bin/env bash
# The network term (L_net, B_net) fitted from the team's own MPI exchanges and checked held out:
# the net-mpi probe, two exchange sweeps of a 3-process team (one to fit, one held out), then
# dtflop calibrate (latency variant: the seed variant has no latency term) and dtflop validate.
#   benchmarks/sar/netfit.sh [OUT]     (default results/sar/net-fit; under a minute)
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-results/sar/net-fit}
dtflop=${DTFLOP:-build/dtflop}
[ -x "$dtflop" ] || { echo "netfit: no $dtflop; build it (cmake --build build --target dtflop)" >&2; exit 2; }
mkdir -p "$out"
rm -f "$out/fit.jsonl" "$out/held.jsonl"
run=(mpirun --oversubscribe -n 3 env OMP_NUM_THREADS=1 "$dtflop" sar --scenario sar/scenarios/table-5.5.yaml)
"$dtflop" probe --only net-mpi -o "$out/probed.json" > "$out/probe.txt" 2>&1
"${run[@]}" --exchange-sweep --repetitions 7 --store "$out/fit.jsonl" 2> "$out/sweep-fit.txt"
"${run[@]}" --exchange-sweep --repetitions 7 --store "$out/held.jsonl" 2> "$out/sweep-held.txt"
"$dtflop" calibrate --store "$out/fit.jsonl" --machine "$out/probed.json" --variant latency --accept-bounds \
  -o "$out/fitted.json" > "$out/calibrate.txt" 2>&1
"$dtflop" validate --store "$out/held.jsonl" --machine "$out/fitted.json" > "$out/validate.txt" 2>&1 || true
{
  echo "made by: benchmarks/sar/netfit.sh $out"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "machine: $(getconf _NPROCESSORS_ONLN) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} > "$out/HOW.txt"
grep -E "^(L_net|B_net) " "$out/calibrate.txt" || true
grep -E "^total" "$out/validate.txt" || true
