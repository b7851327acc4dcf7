#!/bin/sh
# Probe, ABBA: sqp/a, default/a, default/b, sqp/b (README). Run from experiments/realtime_mode2_sqp.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/m2sqp MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part sqp 0 a --ctl mode2.solver=sqp
part default 0 a
part default 12 b
part sqp 12 b --ctl mode2.solver=sqp
