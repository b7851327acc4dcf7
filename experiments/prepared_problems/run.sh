#!/bin/sh
# experiments/prepared_problems (README): run.sh OUT, with worktrees of the declaring commit at
# /work/rp and of its parent at /work/rl.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name worktree half first-seed
  PYTHONPATH=$2 $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $4 --workers 1 --timeout 900 \
    --latency 0.05:strict --out $out/$1/$3
}
arm prepared /work/rp a 8866; arm lazy /work/rl a 8866
arm lazy /work/rl b 8878; arm prepared /work/rp b 8878
