#!/usr/bin/env bash
# The fit's prior (docs/calibration.md, "Prior") against archived calibration runs: each case's
# training store fitted without a prior and with `--prior SIGMA`, both validated on the case's
# held-out store (never fitted). The stores carry their counts, so old runs refit as they were
# measured; what changes is only the fit.
#
#   [DTFLOP=build/dtflop] bash benchmarks/calibrate/prior.sh OUT SIGMA [FOLDER:NAME:SELECTION ...]
#   e.g. bash benchmarks/calibrate/prior.sh prior-out 0.5                 (the cases below, ~15 min on 2 vCPUs)
#
# A case is a results folder holding fit.jsonl.xz, held.jsonl.xz and probed.json, a name for the
# output files, and the samples to fit (`--backend B` and `--match TEXT`, spaces as '+').
# Writes OUT/NAME-{plain,prior}.{calibrate,validate}.txt and OUT/summary.txt.
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${DTFLOP:-build/dtflop}
[ $# -ge 2 ] || { echo "usage: $0 OUT SIGMA [FOLDER:NAME:SELECTION ...]" >&2; exit 2; }
O=$1
S=$2
shift 2
cases=("$@")
if ((${#cases[@]} == 0)); then
  r=results
  cases=(
    "$r/dct-calibration/cpu-2026-11-24b:dct-vm-b-cpu-seq:--backend+cpu-seq"
    "$r/dct-calibration/cpu-2026-11-24b:dct-vm-b-cpu-par:--backend+cpu-par"
    "$r/dct-calibration/cpu-2026-11-27:dct-vm-c-cpu-seq:--backend+cpu-seq"
    "$r/dct-calibration/cpu-2026-11-27:dct-vm-c-cpu-par:--backend+cpu-par"
    "$r/dct-calibration/cpu-2026-11-28:dct-vm-d-cpu-seq:--backend+cpu-seq"
    "$r/dct-calibration/cpu-2026-11-28:dct-vm-d-cpu-par:--backend+cpu-par"
    "$r/dct-calibration/h100-2026-11-27:dct-h100-pinned:--match+host-memory=pinned"
    "$r/dct-calibration/h100-2026-11-27:dct-h100-pageable:--match+host-memory=pageable"
    "$r/rbe-calibration/cpu-2026-11-25:rbe-vm-cpu-seq:--backend+cpu-seq"
    "$r/rbe-calibration/cpu-2026-11-25:rbe-vm-cpu-par:--backend+cpu-par"
    "$r/rbe-calibration/h200-2026-11-24:rbe-h200-cuda-resident:--backend+cuda-resident"
    "$r/rbe-calibration/h200-2026-11-24:rbe-h200-seed-pinned:--backend+cuda-seed+--match+host-memory=pinned"
  )
fi
mkdir -p "$O"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
: > "$O/summary.txt"
for c in "${cases[@]}"; do
  IFS=: read -r folder name selection <<< "$c"
  read -r -a sel <<< "${selection//+/ }"
  for f in fit held; do xz -dc "$folder/$f.jsonl.xz" > "$tmp/$name-$f.jsonl"; done
  for how in plain prior; do
    prior=0
    [ "$how" = prior ] && prior=$S
    base="$O/$name-$how"
    start=$(date +%s)
    if ! "$D" calibrate --store "$tmp/$name-fit.jsonl" --machine "$folder/probed.json" "${sel[@]}" --prior "$prior" \
         --accept-bounds -o "$tmp/$name-$how.json" > "$base.calibrate.txt" 2>&1; then
      echo "$name $how: calibrate failed: $(grep -m1 '^dtflop' "$base.calibrate.txt")" | tee -a "$O/summary.txt"
      continue
    fi
    "$D" validate --store "$tmp/$name-held.jsonl" --machine "$tmp/$name-$how.json" "${sel[@]}" \
      > "$base.validate.txt" 2>&1 || true
    bounds=$(grep -c "BOUND:" "$base.calibrate.txt" || true)
    echo "$name $how (prior $prior): $(grep -m1 '^total:' "$base.validate.txt" | cut -c8-) | at a bound: $bounds | $(( $(date +%s) - start )) s" \
      | tee -a "$O/summary.txt"
  done
done
