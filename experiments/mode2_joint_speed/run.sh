#!/bin/sh
# Part 1, ABBA: bound/a, default/a, default/b, bound/b; then part 2 (README). Run from experiments/mode2_joint_speed.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/jspeed MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part bound 8206 a --ctl mode2.joint_speed_bound=true
part default 8206 a
part default 8218 b
part bound 8218 b --ctl mode2.joint_speed_bound=true
nodelay() {  # arm [--ctl ...]
  arm=$1; shift
  PYTHONPATH=/work/jspeed MUJOCO_GL=egl $UVMS campaign \
    --scenarios thrusters-dead,wall-headon,wall-oblique,arm-deployed --controllers switching --seeds 40 \
    --first-seed 0 --workers 2 --timeout 900 "$@" --out nodelay/$arm
}
nodelay bound --ctl mode2.joint_speed_bound=true
nodelay default
