#!/bin/sh
# Part 1, ABBA: gated/a, default/a, default/b, gated/b (README). Run from experiments/realtime_mode3_thrust.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/gate MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part gated 8104 a --ctl mode3.thrust_horizon=3
part default 8104 a
part default 8116 b
part gated 8116 b --ctl mode3.thrust_horizon=3
