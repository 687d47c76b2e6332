#!/usr/bin/env bash
# Sets everything up, characterizes this machine and writes the report:
#   machine.json           the machine profile (`dtflop probe`)
#   predict-rbe-seed.txt   the seed's RBE pipeline predicted on it (`dtflop predict`)
# Usage: scripts/characterize.sh [output-folder]   (default: ./report)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-report}
scripts/setup.sh
mkdir -p "$out"
./build/dtflop probe -o "$out/machine.json"
./build/dtflop predict --machine "$out/machine.json" rbe-seed --grid 1000x1000 --kernel 33x33 \
    --deadline 1ms | tee "$out/predict-rbe-seed.txt"
echo "characterize: wrote $out/machine.json and $out/predict-rbe-seed.txt" >&2
