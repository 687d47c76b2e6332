#!/usr/bin/env bash
# Sets everything up, characterizes this machine and writes the report into one folder:
#   machine.json         the machine profile (`dtflop probe`)
#   predict-*.txt        the RBE reference workload predicted on it (`dtflop predict`), for each
#                        pipeline this machine can run: the CPU backends always; the seed's GPU
#                        pipeline and the resident one when a GPU was probed
#   run-*.txt            one measured run of the fastest pipeline here beside its prediction
#                        (`dtflop run rbe --machine`)
# Usage: scripts/characterize.sh [output-folder]   (default: ./report)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-report}
scripts/setup.sh
mkdir -p "$out"
dtflop=./build/dtflop
shape=(--grid 1000x1000 --kernel 33x33)

$dtflop probe -o "$out/machine.json"

predict() {  # predict NAME WORKLOAD [options...]
  local name=$1
  shift
  echo "== dtflop predict $* ==" >&2
  $dtflop predict --machine "$out/machine.json" --deadline 1ms "$@" "${shape[@]}" | tee "$out/predict-$name.txt"
}
predict rbe-cpu-seq rbe-cpu-seq
predict rbe-cpu-par rbe-cpu-par
if grep -q '"V_G_fp32"' "$out/machine.json"; then
  predict rbe-seed rbe-seed
  predict rbe-cuda-resident rbe-cuda-resident
  backend=cuda-resident
else
  echo "characterize: no GPU was probed on this machine: GPU pipelines are not predicted" \
       "(try: $dtflop predict --machine docs/examples/h200.json rbe-seed)" >&2
  backend=cpu-par
fi

echo "== dtflop run rbe --backend $backend ==" >&2
$dtflop run rbe --backend "$backend" "${shape[@]}" --steps 50 --machine "$out/machine.json" \
    | tee "$out/run-rbe-$backend.txt"
echo "characterize: wrote the profile, predictions and a measured run into $out/" >&2
