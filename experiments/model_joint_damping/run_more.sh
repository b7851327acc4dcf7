#!/bin/sh
# Part 3, ABBA: damped2/a, default2/a, default2/b, damped2/b (README). Run from experiments/model_joint_damping.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/damp MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part damped2 8182 a --ctl model_joint_damping=true
part default2 8182 a
part default2 8194 b
part damped2 8194 b --ctl model_joint_damping=true
