#!/bin/sh
# Part 2 (README). Run from experiments/model_joint_damping.
set -e
PYTHONPATH=/work/damp MUJOCO_GL=egl /work/main/.venv/bin/uvms campaign \
  --scenarios thrusters-dead,wall-headon,wall-oblique,arm-deployed --controllers switching --seeds 40 \
  --first-seed 0 --workers 2 --timeout 900 --ctl model_joint_damping=true --out nodelay
