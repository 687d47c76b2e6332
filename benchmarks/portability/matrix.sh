#!/usr/bin/env bash
# Prediction portability (docs/portability.md): fits each backend's calibration on one machine,
# carries it to the other machine's probe profile, and validates every basis (calibrated here,
# transferred, probe-only) on held-out samples of each machine, with the 90% intervals' coverage.
# The table it prints is docs/PERFORMANCE.md's "Prediction portability".
#
#   bash benchmarks/portability/matrix.sh [DTFLOP] [OUT]      (about 12 minutes on 2 cores)
#
# Inputs, all in the repository: the H100 run (results/portability/h100-2026-11-24: GPU stores of
# `benchmarks/calibrate/gpu.sh all` with ROUNDS=3, and cpu-held.jsonl, random:50 of cpu-seq and
# cpu-par on its 16-thread host), the H200 run (results/rbe-calibration/h200-2026-11-24) and the
# 2-vCPU VM's CPU run (results/rbe-calibration/cpu-2026-11-21f). Writes the fitted profiles,
# calibrations, fit reports and the table into OUT (default: portability-out).
set -euo pipefail
cd "$(dirname "$0")/../.."
D=$(realpath "${1:-build/dtflop}")
ROW=$(realpath benchmarks/portability/row.py)
O=${2:-portability-out}
mkdir -p "$O"
O=$(realpath "$O")
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
H1=results/portability/h100-2026-11-24 H2=results/rbe-calibration/h200-2026-11-24 VM=results/rbe-calibration/cpu-2026-11-21f
for f in fit held; do
  xz -dc $H1/$f.jsonl.xz > "$W/h100-$f.jsonl"
  xz -dc $H2/$f.jsonl.xz > "$W/h200-$f.jsonl"
  xz -dc $VM/$f.jsonl.xz > "$W/vm-$f.jsonl"
done
xz -dc $H1/cpu-held.jsonl.xz > "$W/h100host-held.jsonl"
cp $H1/probed.json "$W/h100-probed.json"; cp $H2/probed.json "$W/h200-probed.json"; cp $VM/probed.json "$W/vm-probed.json"
cd "$W"

# Fits that end on a physical bound are accepted and listed: the table says which.
cal() {  # machine name selection...
  local m=$1 name=$2; shift 2
  "$D" calibrate --store $m-fit.jsonl --machine $m-probed.json -o "$O/$m-fitted-$name.json" \
    --write-calibration "$O/$m-$name.cal.json" --accept-bounds "$@" > "$O/$m-calibrate-$name.txt" 2>&1
  echo "$m $name: $(grep -o 'Chose [a-z]*' "$O/$m-calibrate-$name.txt")$(grep -o '; [0-9]* parameter(s) at a physical bound ([^)]*)' "$O/$m-calibrate-$name.txt" || true)" >&2
  grep -o '[0-9]* parameter(s) at a physical bound ([^)]*)' "$O/$m-calibrate-$name.txt" || true
}
for m in h100 h200; do
  cal $m cuda-seed-pinned --backend cuda-seed --match host-memory=pinned
  cal $m cuda-seed-pageable --backend cuda-seed --match host-memory=pageable
  cal $m cuda-resident --backend cuda-resident
done
for b in cpu-seq cpu-par; do cal vm $b --backend $b; done

v() { python3 "$ROW" "$D" "$@"; }  # label validate-arguments...: one row of the table
{
  python3 "$ROW" --header
  for s in "cuda-seed-pinned --backend cuda-seed --match host-memory=pinned" \
           "cuda-seed-pageable --backend cuda-seed --match host-memory=pageable" "cuda-resident --backend cuda-resident"; do
    set -- $s; name=$1; shift
    for m in h100 h200; do
      o=$([ $m = h100 ] && echo h200 || echo h100)
      v "$m $name, calibrated here" --store $m-held.jsonl --machine "$O/$m-fitted-$name.json" "$@"
      v "$m $name, transferred from $o" --store $m-held.jsonl --machine $m-probed.json --calibration "$O/$o-$name.cal.json"
      v "$m $name, probe-only" --store $m-held.jsonl --machine $m-probed.json "$@"
    done
  done
  for b in cpu-seq cpu-par; do
    v "vm $b, calibrated here" --store vm-held.jsonl --machine "$O/vm-fitted-$b.json" --backend $b
    v "vm $b, probe-only" --store vm-held.jsonl --machine vm-probed.json --backend $b
    v "h100 host $b, transferred from vm" --store h100host-held.jsonl --machine h100-probed.json --calibration "$O/vm-$b.cal.json"
    v "h100 host $b, probe-only" --store h100host-held.jsonl --machine h100-probed.json --backend $b
  done
} | tee "$O/matrix.md"
# The reports name the files as written here; keep them free of this machine's folders.
sed -i "s|$O/||g" "$O"/*.txt "$O"/matrix.md
