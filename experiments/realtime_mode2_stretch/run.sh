#!/bin/sh
# ABBA: stretch/a, fixed/a, fixed/b, stretch/b (README). Run from experiments/realtime_mode2_stretch.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm worktree first-seed part
  PYTHONPATH=$2 MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $3 --workers 1 --timeout 900 \
    --latency 0.05:strict --out $1/$4
}
part stretch /work/stretch 5000 a
part fixed /work/fixed 5000 a
part fixed /work/fixed 5012 b
part stretch /work/stretch 5012 b
