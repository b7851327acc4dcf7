#!/bin/sh
# experiments/switching_step (README): run.sh OUT, with worktrees of the declaring commit's parent
# (the change) at /work/sp_new and of its parent at /work/sp_old; nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name worktree half first-seed
  PYTHONPATH=$2 $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $4 --workers 1 --timeout 900 \
    --latency 0.05:strict --out $out/$1/$3
}
arm faster /work/sp_new a 8962; arm before /work/sp_old a 8962
arm before /work/sp_old b 8974; arm faster /work/sp_new b 8974
python3 /work/main/experiments/realtime_mode3_thrust/late.py $out/before/a $out/faster/a $out/before/b $out/faster/b > $out/late_steps.txt
