#!/usr/bin/env bash
# Probe-only evidence for one machine (docs/portability.md): a quick probe profile, then held-out
# sets that no fit uses (random:50, the default seed) of the named backends of one workload (RBE, or
# the one WORKLOAD names), in replicate
# rounds, round by round so that every backend's rounds share the machine's slow spells alike;
# then each backend validated against the probe profile alone. Runs on a CPU machine and, from a
# device bundle (scripts/device-bundle.sh -o FOLDER dtflop), on a GPU machine.
#
#   [DTFLOP=build/dtflop] [ROUNDS=3] [WORKLOAD=rbe|dct] bash benchmarks/portability/held-out.sh OUT BACKEND...
#   e.g. bash benchmarks/portability/held-out.sh held-vm cpu-seq cpu-par              (~6 min, 2 vCPU)
#        DTFLOP=.carry-gpu/bin/dtflop bash benchmarks/portability/held-out.sh $OUT/h cpu-seq cpu-par cuda-seed
#
# Writes OUT/probed.json, OUT/probe.txt, OUT/held.jsonl, OUT/log.txt and OUT/validate-BACKEND.txt
# (cuda-seed and DCT's cuda, whose plans draw pinned and pageable frames: one per host memory kind). A store already in OUT is continued, not replaced.
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${DTFLOP:-build/dtflop}
R=${ROUNDS:-3}
W=${WORKLOAD:-rbe}
[ $# -ge 2 ] || { echo "usage: $0 OUT BACKEND... (e.g. $0 held-vm cpu-seq cpu-par)" >&2; exit 2; }
O=$1
shift
mkdir -p "$O"
log="$O/log.txt"
say() { echo "== $* ($(date -u +%H:%M:%S), load $(cut -d' ' -f1-3 /proc/loadavg))" | tee -a "$log"; }
say "probe"
[ -e "$O/probed.json" ] || "$D" probe --quick -o "$O/probed.json" > "$O/probe.txt" 2>&1
for r in $(seq 1 "$R"); do
  for b in "$@"; do
    say "round $r: $b"
    "$D" sweep "$W" --backend "$b" --plan random:50 --rounds "$r" --store "$O/held.jsonl" --quiet 2>&1 | tee -a "$log"
  done
done
say "validate"
for b in "$@"; do
  if [ "$b" = cuda-seed ] || [ "$W/$b" = dct/cuda ]; then
    for m in pinned pageable; do
      "$D" validate --store "$O/held.jsonl" --machine "$O/probed.json" --backend "$b" --match host-memory=$m \
        > "$O/validate-$b-$m.txt" 2>&1 || true
    done
  else
    "$D" validate --store "$O/held.jsonl" --machine "$O/probed.json" --backend "$b" > "$O/validate-$b.txt" 2>&1 || true
  fi
done
grep -H "^total:" "$O"/validate-*.txt || true
