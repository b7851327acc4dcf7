#!/bin/sh
# ABBA: ahead/a, blind/a, blind/b, ahead/b (README). Run from experiments/realtime_late_notice.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm worktree first-seed part
  PYTHONPATH=$2 MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $3 --workers 1 --timeout 900 \
    --latency 0.05:strict --out $1/$4
}
part ahead /work/ahead 5000 a
part blind /work/blind 5000 a
part blind /work/blind 5012 b
part ahead /work/ahead 5012 b
