#!/bin/sh
# experiments/realtime_bar_8626 (README): run.sh OUT, with a worktree of the declaring commit at /work/rb.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
run() {  # name controller latency workers
  PYTHONPATH=/work/rb $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers $2 \
    --seeds 24 --first-seed 8626 --workers $4 --timeout 900 --latency $3 --out $out/$1
}
run none switching none 2
run strict50 switching 0.05:strict 1
run strict20 switching 0.02:strict 1
run measured switching-measured measured 1
