#!/usr/bin/env bash
# cuda-resident between the two GPU kinds the device tool lends: fits each machine's calibration
# on its own training store, carries it to the other machine's probe profile, and validates every
# basis (calibrated here, transferred, probe-only) on each machine's held-out store, with the
# 90% intervals' coverage: docs/PERFORMANCE.md, "Prediction portability".
#
#   bash benchmarks/portability/resident-transfer.sh [DTFLOP] [RUN] [OUT]    (about 3 minutes on 2 cores)
#
# RUN (default results/portability/transfer-2026-11-25) holds h100/ and h200/, each with
# fit.jsonl.xz and held.jsonl.xz (`benchmarks/calibrate/gpu.sh resident`) and probed.json (a quick
# probe of the same kind of machine). Writes the fitted profiles, calibrations, fit reports and
# the table (matrix.md) into OUT (default transfer-out).
set -euo pipefail
cd "$(dirname "$0")/../.."
D=$(realpath "${1:-build/dtflop}")
ROW=$(realpath benchmarks/portability/row.py)
RUN=$(realpath "${2:-results/portability/transfer-2026-11-25}")
O=${3:-transfer-out}
mkdir -p "$O"
O=$(realpath "$O")
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
cd "$W"
for m in h100 h200; do
  xz -dc "$RUN/$m/fit.jsonl.xz" > $m-fit.jsonl
  xz -dc "$RUN/$m/held.jsonl.xz" > $m-held.jsonl
  cp "$RUN/$m/probed.json" $m-probed.json
  # Fits that end on a physical bound are accepted and listed in the report.
  "$D" calibrate --store $m-fit.jsonl --machine $m-probed.json --backend cuda-resident --accept-bounds \
    -o "$O/$m-fitted-cuda-resident.json" --write-calibration "$O/$m-cuda-resident.cal.json" \
    > "$O/$m-calibrate-cuda-resident.txt" 2>&1
done
v() { python3 "$ROW" "$D" "$@"; }  # label validate-arguments...: one row of the table
{
  python3 "$ROW" --header
  for m in h100 h200; do
    o=$([ $m = h100 ] && echo h200 || echo h100)
    v "$m cuda-resident, calibrated here" --store $m-held.jsonl --machine "$O/$m-fitted-cuda-resident.json" --backend cuda-resident
    v "$m cuda-resident, transferred from $o" --store $m-held.jsonl --machine $m-probed.json --calibration "$O/$o-cuda-resident.cal.json"
    v "$m cuda-resident, probe-only" --store $m-held.jsonl --machine $m-probed.json --backend cuda-resident
  done
} | tee "$O/matrix.md"
sed -i "s|$O/||g; s|$W/||g" "$O"/*.txt "$O"/matrix.md
