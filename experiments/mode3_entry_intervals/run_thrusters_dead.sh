#!/bin/sh
# experiments/mode3_entry_intervals (README, "thrusters-dead"): run_thrusters_dead.sh OUT, at the
# adopting commit. A fixed delay is deterministic (the plant waits), so the arms run side by side.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios thrusters-dead --controllers switching --seeds 24 --first-seed 0 --workers 1 \
    --timeout 900 --latency 0.05 "$@" --out $out/$n
}
arm full --ctl mode3_entry_intervals=none & arm entry2; wait
