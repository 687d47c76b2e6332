#!/usr/bin/env bash
# Test 4 of the seed (Figures 5.15-5.16): the rescue, Monte Carlo over seeds, for observation
# fusion, belief fusion every k = 1, 5, 50, 500 steps, the log-linear pool (k = 5) and no
# sharing, each helicopter one MPI process (3, on however many cores: --oversubscribe).
#   benchmarks/sar/test4.sh [SEEDS] [OUT]     (default 100 seeds, results/sar/test4)
# Then `python3 benchmarks/sar/summarize.py OUT` makes the tables and figures (docs/sar.md).
# The scenario is sar/scenarios/table-5.5.yaml; every run uses cpu-seq (one thread per process,
# so three processes share two cores fairly) and the link model (70 Mbit/s, 2 ms) in simulated
# time. About 0.6 s a run on the 2-core VM: 700 runs, 7 minutes.
set -euo pipefail
cd "$(dirname "$0")/../.."
seeds=${1:-100}
out=${2:-results/sar/test4}
dtflop=${DTFLOP:-build/dtflop}
[ -x "$dtflop" ] || { echo "test4: no $dtflop; build first (cmake --build build)" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] && export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMP_NUM_THREADS=1
mkdir -p "$out"
scenario=sar/scenarios/table-5.5.yaml
run() {  # NAME RULE [INTERVAL]
  local name=$1 rule=$2 interval=${3:-1}
  if [ -s "$out/$name/summary.jsonl" ] && [ "$(wc -l < "$out/$name/summary.jsonl")" -ge "$seeds" ]; then
    # (rerun from scratch: remove $out/$name)
    echo "test4: $name done earlier" >&2; return
  fi
  echo "test4: $name ($(date -u +%H:%M:%S))" >&2
  mpirun --oversubscribe -n 3 "$dtflop" sar --scenario "$scenario" --rule "$rule" --interval "$interval" \
    --backend cpu-seq --seeds "1..$seeds" --no-records --quiet --out "$out/$name"
}
run observation observation
run belief-k1 belief 1
run belief-k5 belief 5
run belief-k50 belief 50
run belief-k500 belief 500
run loglinear-k5 loglinear 5
run none none
# One run of each with snapshots and the per-step records (Figure 5.15).
for r in "observation observation 1" "belief-k5 belief 5" "loglinear-k5 loglinear 5"; do
  set -- $r
  mpirun --oversubscribe -n 3 "$dtflop" sar --scenario "$scenario" --rule "$2" --interval "$3" --backend cpu-seq \
    --seeds 1 --snapshots 0,40,80,200 --quiet --out "$out/snapshots-$1"
done
# The per-seed series, archived (xz) per configuration: summarize.py reads them from there.
for d in "$out"/*/; do
  if compgen -G "$d/seed-*-series.csv" > /dev/null && [ ! -e "$d/snapshots" ] && [[ "$d" != *snapshots-* ]]; then
    (cd "$d" && tar -cJf series.tar.xz seed-*-series.csv && rm -f seed-*-series.csv)
  fi
done
{
  echo "made by: benchmarks/sar/test4.sh $seeds $out"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "machine: $(getconf _NPROCESSORS_ONLN) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
  echo "mpirun: $(mpirun --version | head -n 1)"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} > "$out/HOW.txt"
echo "test4: done; python3 benchmarks/sar/summarize.py $out" >&2
