#!/usr/bin/env bash
# Test 3 of the seed (Figures 5.13-5.14): wall time of a team step (3 MPI processes, real
# messages) with observation fusion against belief fusion, against the grid size (k = 1) and
# against the fusion interval k (grid 180x80), each with the link model held back in wall time
# (--link sleep: 70 Mbit/s, 2 ms a message) and without a link (--link off: the messages alone);
# beside each, the DTFLOP model's prediction (`dtflop predict sar` on a probe of this machine:
# the RBE step, the host work, the network term priced by the MPI ping-pong, plus the link
# model's delay) and the prediction's error.
#   benchmarks/sar/test3.sh [OUT]      (default results/sar/test3; about 3 minutes)
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-results/sar/test3}
dtflop=${DTFLOP:-build/dtflop}
[ -x "$dtflop" ] || { echo "test3: no $dtflop; build first" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] && export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMP_NUM_THREADS=1
mkdir -p "$out"
# The machine may be shared: its load before and after the runs goes into HOW.txt.
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
scenario=sar/scenarios/table-5.5.yaml
[ -s "$out/machine.json" ] || "$dtflop" probe --quick -o "$out/machine.json" > "$out/probe.txt" 2>&1
: > "$out/load.txt"
echo "series,rule,interval,cells,link,measured_step_s,predicted_step_s,predicted_link_s,relative_error" > "$out/test3.csv"
one() {  # SERIES RULE INTERVAL CELLS LINK
  local series=$1 rule=$2 k=$3 cells=$4 link=$5 dir="$out/runs/$1-$2-k$3-$4-$5"
  rm -rf "$dir"
  mpirun --oversubscribe -n 3 "$dtflop" sar --scenario "$scenario" --rule "$rule" --interval "$k" --cells "$cells" \
    --link "$link" --backend cpu-seq --steps 60 --no-records --quiet --out "$dir"
  local measured predicted delay
  measured=$(python3 -c "import json;print(json.loads(open('$dir/summary.jsonl').readline())['wall_step_mean'])")
  "$dtflop" predict sar --scenario "$scenario" --rule "$rule" --interval "$k" --cells "$cells" --backend cpu-seq \
    --machine "$out/machine.json" --json > "$dir/predict.json" 2> "$dir/predict.err"
  read -r predicted delay < <(python3 -c "
import json; p = json.load(open('$dir/predict.json'))
link = p['link_delay_per_step'] if '$link' == 'sleep' else 0.0
print(p['total_per_step'] + link, link)")
  python3 -c "m=$measured; p=$predicted; print('$series,$rule,$k,$cells,$link,%.6g,%.6g,%.6g,%.3f' % (m, p, $delay, (p - m) / m))" >> "$out/test3.csv"
  tail -n 1 "$out/test3.csv" >&2
  # What else ran (a shared machine): the load and the busiest other processes after each run.
  echo "$series,$rule,$k,$cells,$link: load $(cut -d' ' -f1 /proc/loadavg); $(ps -eo pcpu,comm --sort=-pcpu |
    grep -v -e dtflop -e mpirun -e ' ps$' | sed -n 2,3p | tr -s ' ' | tr '\n' ';')" >> "$out/load.txt"
}
for link in sleep off; do
  for n in 45x20 90x40 180x80 360x160; do
    one grid observation 1 "$n" "$link"
    one grid belief 1 "$n" "$link"
  done
  for k in 1 2 5 10 20 50; do one interval belief "$k" 180x80 "$link"; done
  one interval observation 1 180x80 "$link"
done
{
  echo "made by: benchmarks/sar/test3.sh $out"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "machine: $(getconf _NPROCESSORS_ONLN) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); 3 processes oversubscribed"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "load average (1, 5, 15 min) before: $load_before; after: $(cut -d' ' -f1-3 /proc/loadavg)"
} > "$out/HOW.txt"
python3 - "$out" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1] + "/test3.csv")))
# Probe-only: the model as the probe prices it. Calibrated: one factor on the model's part (not
# the link's), the median of measured / predicted over the grid series without the link (the
# training set), applied to every run; the interval series are held out.
train = [r for r in rows if r["series"] == "grid" and r["link"] == "off"]
factor = statistics.median(float(r["measured_step_s"]) / float(r["predicted_step_s"]) for r in train)
md = [f"Calibration factor on the model's part: {factor:.2f} (median of measured / predicted over the "
      f"{len(train)} grid runs without the link)", "",
      "| series | rule | k | cells | link | measured per step | predicted (probe-only) | link part | error | "
      "calibrated | error |", "| --- " * 11 + "|"]
errors = {}
for r in rows:
    m, p, l = float(r["measured_step_s"]), float(r["predicted_step_s"]), float(r["predicted_link_s"])
    c = factor * (p - l) + l
    held = r["series"] == "interval"
    errors.setdefault((r["link"], "probe-only", held), []).append(abs(p - m) / m)
    errors.setdefault((r["link"], "calibrated", held), []).append(abs(c - m) / m)
    md.append(f"| {r['series']} | {r['rule']} | {r['interval']} | {r['cells']} | {r['link']} | {m * 1e3:.3f} ms | "
              f"{p * 1e3:.3f} ms | {l * 1e3:.3f} ms | {(p - m) / m * 100:+.0f}% | {c * 1e3:.3f} ms | "
              f"{(c - m) / m * 100:+.0f}% |")
md.append("")
for (link, basis, held), e in sorted(errors.items()):
    md.append(f"- link {link}, {basis}, {'held-out (interval series)' if held else 'grid series'}: mean |error| "
              f"{statistics.fmean(e) * 100:.0f}%, max {max(e) * 100:.0f}% over {len(e)} runs")
open(sys.argv[1] + "/test3.md", "w").write("\n".join(md) + "\n")
print("\n".join(md))
PY
