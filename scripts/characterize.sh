#!/usr/bin/env bash
# The main job: sets everything up (Debian packages, the build) and runs `dtflop characterize`,
# which probes this machine, sweeps both reference workloads on every backend it can run (the
# GPU ones where a GPU was probed), fits the model to the training sweeps, validates it on
# held-out sweeps and writes the reports, all into one folder (default: report/). It prints
# where the reports are and the headline numbers; progress goes to stderr. Rerun it after an
# interruption and it resumes. docs/cli.md, "characterize", lists what the folder holds.
# Usage: scripts/characterize.sh [--quick|--full] [--no-setup] [--dtflop PATH] [folder]
#   --quick      quick probe, small plans (the test suite runs the main job this way)
#   --full       the dissertation's plans for the fit, 50 random configurations held out (long)
#   --no-setup   use the dtflop already built (at --dtflop, default build/dtflop); install nothing
# Exit status: dtflop's (0 when every step worked).
set -euo pipefail
cd "$(dirname "$0")/.."
args=()
setup=1
dtflop=./build/dtflop
out=report
while (($#)); do
  case $1 in
    --quick|--full) args+=("$1") ;;
    --no-setup) setup=0 ;;
    --dtflop) shift; dtflop=${1:?--dtflop needs a path} ;;
    -h|--help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "characterize: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) out=$1 ;;
  esac
  shift
done
((setup)) && scripts/setup.sh
[ -x "$dtflop" ] || { echo "characterize: no dtflop at $dtflop; build it (scripts/setup.sh) or give --dtflop" >&2; exit 2; }
exec "$dtflop" characterize "${args[@]}" -o "$out"
