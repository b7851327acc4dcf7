#!/bin/sh
# experiments/measured_actuators (README): run.sh OUT, with worktrees of 81a68d5 at /work/mh and
# of the declaring commit at /work/mp.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name worktree half first-seed latency workers
  PYTHONPATH=$2 $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching-measured --seeds 12 --first-seed $4 --workers $6 --timeout 900 \
    --latency $5 --out $out/$1/$3
}
arm hold /work/mh a 8698 measured 1; arm play /work/mp a 8698 measured 1
arm play /work/mp b 8710 measured 1; arm hold /work/mh b 8710 measured 1
PYTHONPATH=/work/mp $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
  --seeds 24 --first-seed 8698 --workers 2 --timeout 900 --out $out/none
