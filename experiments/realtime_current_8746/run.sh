#!/bin/sh
# experiments/realtime_current_8746 (README): run.sh OUT, with a worktree of the declaring commit at /work/rt.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
run() {  # name controller latency
  PYTHONPATH=/work/rt $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers $2 \
    --seeds 24 --first-seed 8746 --workers 1 --timeout 900 --latency $3 --out $out/$1
}
run strict20 switching 0.02:strict
run measured switching-measured measured
