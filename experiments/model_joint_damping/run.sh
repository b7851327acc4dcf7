#!/bin/sh
# Part 1, ABBA: damped/a, default/a, default/b, damped/b (README). Run from experiments/model_joint_damping.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/damp MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part damped 8158 a --ctl model_joint_damping=true
part default 8158 a
part default 8170 b
part damped 8170 b --ctl model_joint_damping=true
