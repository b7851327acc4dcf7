#!/bin/sh
# ABBA: measured/a, told/a, told/b, measured/b (README). Run from experiments/realtime_heldout_8080.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm preset first-seed part
  PYTHONPATH=/work/heldout MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers $2 --seeds 12 --first-seed $3 --workers 1 --timeout 900 --latency measured --out $1/$4
}
part measured switching-measured 8080 a
part told switching 8080 a
part told switching 8092 b
part measured switching-measured 8092 b
