#!/bin/sh
# experiments/measured_release_confirm (README): run.sh OUT, with a worktree of 71e6be9 at /work/mr.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [ctl]
  PYTHONPATH=/work/mr $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching-measured --seeds 12 --first-seed $3 --workers 1 --timeout 900 \
    --latency measured $4 --out $out/$1/$2
}
arm asap a 8842 "--ctl release_at_latency=false"; arm release a 8842
arm release b 8854; arm asap b 8854 "--ctl release_at_latency=false"
