#!/usr/bin/env bash
# The main job: sets everything up, characterizes this machine and writes the report into one folder:
#   machine.json          the machine profile (`dtflop probe`)
#   predict-W-B.txt/json  each reference workload W predicted on it (`dtflop predict`) for every
#                         backend B this machine can run: the CPU backends always, the GPU ones when
#                         a GPU was probed. Where the profile lacks a parameter only a calibration
#                         finds, the prediction uses the richest model variant it supports and says so
#   run-W-B.txt/json      one measured run of each workload on the fastest backend here, beside its
#                         prediction (`dtflop run --machine`)
# Usage: scripts/characterize.sh [--quick] [--no-setup] [--dtflop PATH] [output-folder]
#   --quick      short probes and runs (the test suite runs the main job this way)
#   --no-setup   use the dtflop already built (at --dtflop, default build/dtflop); install nothing
# Exit status: 0 when every step worked, else the failing step's.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
setup=1
dtflop=./build/dtflop
out=report
while (($#)); do
  case $1 in
    --quick) quick=1 ;;
    --no-setup) setup=0 ;;
    --dtflop) shift; dtflop=${1:?--dtflop needs a path} ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "characterize: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) out=$1 ;;
  esac
  shift
done
((setup)) && scripts/setup.sh
[ -x "$dtflop" ] || { echo "characterize: no dtflop at $dtflop; build it (scripts/setup.sh) or give --dtflop" >&2; exit 2; }
mkdir -p "$out"
# The report's own files from an earlier run are replaced; nothing else in the folder is touched.
rm -f "$out"/machine.json "$out"/probe.txt "$out"/predict-*.txt "$out"/predict-*.json "$out"/run-*.txt "$out"/run-*.json

probe_args=()
run_args=()
if ((quick)); then
  probe_args=(--quick)
  run_args=(--reps 3 --warmup 1)
fi

echo "== dtflop probe ${probe_args[*]} ==" >&2
"$dtflop" probe "${probe_args[@]}" -o "$out/machine.json" | tee "$out/probe.txt"

if grep -q '"V_G_fp32"' "$out/machine.json"; then
  gpu=1
else
  gpu=0
  echo "characterize: no GPU was probed on this machine: GPU backends are not predicted" \
       "(try: $dtflop predict rbe --backend cuda-resident --machine docs/examples/h200.json)" >&2
fi

# workload, its CPU backends, its GPU backends, its configuration for the report
declare -A cpu_backends=([rbe]="cpu-seq cpu-par" [dct]="cpu-seq cpu-par")
declare -A gpu_backends=([rbe]="cuda-seed cuda-resident" [dct]="cuda")
declare -A config=([rbe]="--grid 1000x1000 --kernel 33x33" [dct]="")
((quick)) && config[dct]="--size 1600x1200 --dots 400"

for w in rbe; do
  backends=${cpu_backends[$w]}
  ((gpu)) && backends+=" ${gpu_backends[$w]}"
  for b in $backends; do
    echo "== dtflop predict $w --backend $b ${config[$w]} ==" >&2
    # shellcheck disable=SC2086
    "$dtflop" predict "$w" --backend "$b" ${config[$w]} --machine "$out/machine.json" \
        -o "$out/predict-$w-$b.json" | tee "$out/predict-$w-$b.txt"
  done
  if ((gpu)); then run_backend=${gpu_backends[$w]##* }; else run_backend=cpu-par; fi
  echo "== dtflop run $w --backend $run_backend ${config[$w]} ==" >&2
  # shellcheck disable=SC2086
  "$dtflop" run "$w" --backend "$run_backend" ${config[$w]} "${run_args[@]}" --machine "$out/machine.json" \
      -o "$out/run-$w-$run_backend.json" | tee "$out/run-$w-$run_backend.txt"
done
echo "characterize: wrote the profile, predictions and measured runs into $out/" >&2
