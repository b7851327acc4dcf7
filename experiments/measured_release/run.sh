#!/bin/sh
# experiments/measured_release (README): run.sh OUT, with a worktree of the declaring commit at /work/mr.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [ctl]
  PYTHONPATH=/work/mr $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching-measured --seeds 12 --first-seed $3 --workers 1 --timeout 900 \
    --latency measured $4 --out $out/$1/$2
}
arm release a 8818; arm asap a 8818 "--ctl release_at_latency=false"
arm asap b 8830 "--ctl release_at_latency=false"; arm release b 8830
PYTHONPATH=/work/mr $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
  --seeds 24 --first-seed 8818 --workers 2 --timeout 900 --out $out/none
