#!/bin/sh
# Part 2, ABBA: measured_gated/a, measured_default/a, measured_default/b, measured_gated/b (README). Run from experiments/realtime_mode3_thrust.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/gate MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching-measured --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency measured "$@" --out $arm/$name
}
part measured_gated 8104 a --ctl mode3.thrust_horizon=3
part measured_default 8104 a
part measured_default 8116 b
part measured_gated 8116 b --ctl mode3.thrust_horizon=3
