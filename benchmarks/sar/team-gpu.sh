#!/usr/bin/env bash
# The resident team step on a lent GPU machine (docs/sar.md, "The team step on a GPU"): first the
# CUDA tests of what the team step relies on (the summary where the belief lives, the windowed
# likelihood and the new kernel, fusion, the estimate), then bench_sar_team: 3 helicopters of
# sar/scenarios/table-5.5.yaml in threads of one process (the GPU machine has no OpenMPI: the
# platforms exchange through memory, the link model's delay in physical time only), belief
# fusion every 5 steps, on cuda-resident and cpu-par (cpu-par: the host's threads divided among
# the 3 platforms), at each grid of GRIDS. At 4000x4000 the steps the link stretches need a
# kernel as tall as the grid: cuda-resident runs it with its chunked split passes (docs/rbe.md),
# which test_rbe_gpu (against cpu-seq) and test_calibrate_gpu (the launches and copies CUPTI
# sees against the counts) check first, with the windowed test's kernel as tall as the grid.
# Bundle first, here:
#   scripts/device-bundle.sh -o .carry-sar-team bench_sar_team test_rbe_summary_gpu test_rbe_windowed_gpu \
#     test_sar_fusion_gpu test_rbe_estimate_gpu test_rbe_gpu test_calibrate_gpu
# then on the GPU machine, naming the commit the bundle was built from:
#   COMMIT=$(git rev-parse --short HEAD) BUNDLE=.carry-sar-team OUT=$OUT bash benchmarks/sar/team-gpu.sh
#   (GRIDS=1000x1000,4000x4000 STEPS=40 by default; about 4 minutes on an H100 host of 16 cores,
#   plus the tests)
# Writes OUT/team.csv (bench_sar_team's columns), OUT/tests.txt, OUT/machine.txt, OUT/log.txt, OUT/HOW.txt.
set -uo pipefail
[ -n "${COMMIT:-}" ] || { echo "team-gpu.sh: name the commit the bundle was built from: COMMIT=\$(git rev-parse --short HEAD) BUNDLE=... bash benchmarks/sar/team-gpu.sh" >&2; exit 2; }
cd "$(dirname "$0")/../.."
bundle=${BUNDLE:-.carry-sar-team}
[ -x "$bundle/bin/bench_sar_team" ] || { echo "team-gpu.sh: no $bundle/bin/bench_sar_team: run scripts/device-bundle.sh -o $bundle bench_sar_team test_rbe_summary_gpu test_rbe_windowed_gpu test_sar_fusion_gpu test_rbe_estimate_gpu test_rbe_gpu test_calibrate_gpu first" >&2; exit 2; }
export LD_LIBRARY_PATH=$PWD/$bundle/lib:${LD_LIBRARY_PATH:-}
O=${OUT:-team-gpu-out}
grids=${GRIDS:-1000x1000,4000x4000}
steps=${STEPS:-40}
mkdir -p "$O"
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv; echo "cores: $(nproc)"; date -u; } > "$O/machine.txt" 2>&1
: > "$O/tests.txt"
# Each test: name and the gtest filter ('*': all of it). Of test_calibrate_gpu only the chunked
# passes' CUPTI check (the rest is benchmarks/calibrate/gpu.sh's).
for spec in test_rbe_summary_gpu:'*' test_rbe_windowed_gpu:'*' test_sar_fusion_gpu:'*' test_rbe_estimate_gpu:'*' \
            test_rbe_gpu:'*' test_calibrate_gpu:'CalibCupti.CudaResidentChunked*'; do
  t=${spec%%:*}
  filter=${spec#*:}
  [ -x "$bundle/bin/$t" ] || { echo "$t: not in the bundle" | tee -a "$O/log.txt"; continue; }
  timeout 300 "$bundle/bin/$t" --gtest_filter="$filter" >> "$O/tests.txt" 2>&1
  echo "$t: exit $?" | tee -a "$O/log.txt"
done
timeout 480 "$bundle/bin/bench_sar_team" --scenario sar/scenarios/table-5.5.yaml --cells "$grids" \
  --backends cuda-resident,cpu-par --rule belief --interval 5 --steps "$steps" -o "$O/team.csv" 2>> "$O/log.txt"
echo "bench_sar_team: exit $?" | tee -a "$O/log.txt"
{
  echo "made by: COMMIT=$COMMIT BUNDLE=$bundle GRIDS=$grids STEPS=$steps bash benchmarks/sar/team-gpu.sh"
  echo "commit: $COMMIT (named by the caller: the bundle's build)"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
} > "$O/HOW.txt"
grep -h "^bench_sar_team: .*team step" "$O/log.txt"
grep -h -E "^\[  (PASSED|FAILED|SKIPPED)" "$O/tests.txt"
