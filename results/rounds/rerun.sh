#!/usr/bin/env bash
# Re-fits and re-validates every stored calibration experiment that has replicate rounds, once
# per way of combining the rounds (--rounds-combine), from the stores alone (no GPU needed):
#   bash results/rounds/rerun.sh OUT_DIR [JOBS] [EXPERIMENT...]   (DTFLOP=path/to/dtflop, default build/dtflop)
# Per experiment, setup and rule it writes OUT_DIR/<experiment>/<setup>-<rule>.{calibrate.txt,
# fitted.json,validate.txt,validate.json}, with the options the original runs used (calibrate's
# defaults, among them --variant all: the variant chosen by 5-fold cross-validation; validate: the
# fit's variant). VARIANT=original fits the variant the original run chose with the median of
# rounds (its fitted profile's model_variant) instead of cross-validating: ~5x faster, the same
# fit whenever the rule does not change the choice. Then: python3 results/rounds/tabulate.py OUT_DIR...
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${DTFLOP:-build/dtflop}
O=${1:?usage: rerun.sh OUT_DIR [JOBS]}
J=${2:-2}
shift $(( $# < 2 ? $# : 2 ))
ONLY=" $* "
VARIANT=${VARIANT:-all}
# The stored experiments: results/rbe-calibration/ once the results move there, before that
# benchmarks/calibrate/results/ (RESULTS=... names another). An experiment not there is skipped.
R=${RESULTS:-$( [[ -d results/rbe-calibration ]] && echo results/rbe-calibration || echo benchmarks/calibrate/results )}
RULES="median fastest p25"
mkdir -p "$O/stores"
# experiment  store-folder  fit-store  held-store  setups
experiments() {
  for e in cpu-2026-11-21c cpu-2026-11-21d cpu-2026-11-21e cpu-2026-11-21f; do echo "$e $R/$e fit held cpu-seq,cpu-par"; done
  echo "h200-2026-11-21c $R/h200-2026-11-21c fit-seed held-seed pinned,pageable"
  echo "h200-2026-11-21c-resident $R/h200-2026-11-21c/resident fit held resident"
  for e in d e f g i; do echo "h200-2026-11-21$e $R/h200-2026-11-21$e fit held pinned,pageable,resident"; done
  for e in h j r1; do echo "h200-2026-11-21$e $R/h200-2026-11-21$e fit held resident"; done
}
# Stores are kept xz-compressed for the current runs; the earlier runs' gzip stores are in the
# history (results/README.md): restore one beside its summaries to include it.
unpack() {  # STORE-PATH-WITHOUT-EXTENSION -> stdout
  if [[ -f "$1.jsonl.xz" ]]; then xz -dc "$1.jsonl.xz"; else gzip -dc "$1.jsonl.gz"; fi
}
jobs=()
while read -r exp dir fit held setups; do
  [[ "$ONLY" == "  " || "$ONLY" == *" $exp "* ]] || continue
  [[ -f "$dir/$fit.jsonl.xz" || -f "$dir/$fit.jsonl.gz" ]] || { echo "skipped $exp: no stores in $dir (results/README.md: restore them from the history)"; continue; }
  mkdir -p "$O/stores/$exp" "$O/$exp"
  for s in "$fit" "$held"; do unpack "$dir/$s" > "$O/stores/$exp/$s.jsonl"; done
  for setup in ${setups//,/ }; do
    for rule in $RULES; do jobs+=("$exp $dir $fit $held $setup $rule"); done
  done
done < <(experiments)

one() {  # exp dir fit held setup rule
  local exp=$1 dir=$2 fit=$3 held=$4 setup=$5 rule=$6 sel
  case $setup in
    pinned) sel=(--backend cuda-seed --match /pinned/) ;;
    pageable) sel=(--backend cuda-seed --match /pageable/) ;;
    resident) sel=(--backend cuda-resident) ;;
    *) sel=(--backend "$setup") ;;
  esac
  local out="$O/$exp/$setup-$rule" variant=$VARIANT name=$setup
  if [[ "$variant" == original ]]; then
    case $setup in pinned | pageable) name=cuda-seed-$setup ;; resident) name=cuda-resident ;; esac
    local orig="$dir/fitted-$name.json"
    [[ -f "$orig" ]] || orig="$dir/fitted-$name-median.json"
    variant=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["metadata"]["model_variant"])' "$orig")
  fi
  "$D" calibrate --variant "$variant" --store "$O/stores/$exp/$fit.jsonl" "${sel[@]}" --machine "$dir/probed.json" -o "$out.fitted.json" \
    --rounds-combine "$rule" > "$out.calibrate.txt" 2>&1 || { echo "calibrate failed: $out"; return 0; }
  "$D" validate --store "$O/stores/$exp/$held.jsonl" "${sel[@]}" --machine "$out.fitted.json" --rounds-combine "$rule" \
    > "$out.validate.txt" 2>&1 || true
  "$D" validate --store "$O/stores/$exp/$held.jsonl" "${sel[@]}" --machine "$out.fitted.json" --rounds-combine "$rule" \
    --json > "$out.validate.json" 2>/dev/null || true
  echo "done $exp $setup $rule"
}
export -f one
export D O VARIANT
printf '%s\n' "${jobs[@]}" | xargs -P "$J" -L 1 bash -c 'one "$@"' _
rm -rf "$O/stores"
