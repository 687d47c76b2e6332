#!/usr/bin/env bash
# One backend between the two GPU kinds the device tool lends: fits each machine's calibration on
# its own training store, carries it to the other machine's probe profile, and validates every
# basis (calibrated here, transferred, probe-only) on each machine's held-out store, with the 90%
# intervals' coverage: docs/PERFORMANCE.md, "Prediction portability".
#
#   bash benchmarks/portability/transfer.sh [DTFLOP] [RUN] [OUT] [SETUP...]   (1-3 minutes a setup on 2 cores)
#
# RUN (default results/portability/transfer-2026-11-25) holds one folder per machine (MACHINES, two
# names, default "h100 h200"; e.g. MACHINES="lend1 lend2" for two lends of one GPU kind), each with
# fit.jsonl.xz and held.jsonl.xz (e.g. `benchmarks/calibrate/gpu.sh resident` or `seed`) and
# probed.json (a quick probe of the same kind of machine; PROBE=FILE names another file there, e.g.
# PROBE=probed-full.json for a full probe of the same lend). A SETUP is a name and the arguments
# that select its samples, in one word list (default "cuda-resident --backend cuda-resident"), e.g.
#   "cuda-seed-pinned --backend cuda-seed --match host-memory=pinned"
# Writes the fitted profiles, calibrations, fit reports and the table (matrix.md) into OUT
# (default transfer-out). FIT=0 keeps the fits and calibrations already in OUT and only validates
# (the table again, e.g. after a change to how predictions are made; the fits take minutes each).
set -euo pipefail
cd "$(dirname "$0")/../.."
D=$(realpath "${1:-build/dtflop}")
ROW=$(realpath benchmarks/portability/row.py)
RUN=$(realpath "${2:-results/portability/transfer-2026-11-25}")
O=${3:-transfer-out}
shift $(( $# < 3 ? $# : 3 ))
setups=("$@")
[ ${#setups[@]} -gt 0 ] || setups=("cuda-resident --backend cuda-resident")
mkdir -p "$O"
O=$(realpath "$O")
read -r -a machines <<< "${MACHINES:-h100 h200}"
[ ${#machines[@]} -eq 2 ] || { echo "MACHINES names two folders of $RUN, e.g. MACHINES=\"h100 h200\"" >&2; exit 2; }
for m in "${machines[@]}"; do
  for f in fit.jsonl.xz held.jsonl.xz "${PROBE:-probed.json}"; do
    [ -f "$RUN/$m/$f" ] || { echo "no $RUN/$m/$f: each machine's folder needs fit.jsonl.xz, held.jsonl.xz and its probe" >&2; exit 2; }
  done
done
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
cd "$W"
for m in "${machines[@]}"; do
  xz -dc "$RUN/$m/fit.jsonl.xz" > $m-fit.jsonl
  xz -dc "$RUN/$m/held.jsonl.xz" > $m-held.jsonl
  cp "$RUN/$m/${PROBE:-probed.json}" $m-probed.json
done
for s in "${setups[@]}"; do
  # shellcheck disable=SC2086
  set -- $s
  name=$1
  shift
  for m in "${machines[@]}"; do
    if [ "${FIT:-1}" = 0 ]; then
      [ -f "$O/$m-fitted-$name.json" ] && [ -f "$O/$m-$name.cal.json" ] ||
        { echo "FIT=0 but $O has no $m-fitted-$name.json and $m-$name.cal.json: run without FIT=0 first" >&2; exit 2; }
      continue
    fi
    # Fits that end on a physical bound are accepted and listed in the report.
    "$D" calibrate --store $m-fit.jsonl --machine $m-probed.json "$@" --accept-bounds \
      -o "$O/$m-fitted-$name.json" --write-calibration "$O/$m-$name.cal.json" > "$O/$m-calibrate-$name.txt" 2>&1
  done
done
v() { python3 "$ROW" "$D" "$@"; }  # label validate-arguments...: one row of the table
{
  python3 "$ROW" --header
  for s in "${setups[@]}"; do
    # shellcheck disable=SC2086
    set -- $s
    name=$1
    shift
    for m in "${machines[@]}"; do
      o=$([ "$m" = "${machines[0]}" ] && echo "${machines[1]}" || echo "${machines[0]}")
      v "$m $name, calibrated here" --store $m-held.jsonl --machine "$O/$m-fitted-$name.json" "$@"
      v "$m $name, transferred from $o" --store $m-held.jsonl --machine $m-probed.json --calibration "$O/$o-$name.cal.json" "${@:3}"
      v "$m $name, probe-only" --store $m-held.jsonl --machine $m-probed.json "$@"
    done
  done
} | tee "$O/matrix.md"
sed -i "s|$O/||g; s|$W/||g" "$O"/*.txt "$O"/matrix.md
