#!/bin/sh
# Part 4 (README). Run from experiments/realtime_mode3_thrust, at the commit that adopts the gate.
set -e
UVMS=/work/main/.venv/bin/uvms
PYTHONPATH=/work/gate MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
  --controllers switching --seeds 24 --first-seed 8104 --workers 2 --timeout 900 --out nodelay_8104
PYTHONPATH=/work/gate MUJOCO_GL=egl $UVMS campaign --scenarios thrusters-dead,wall-headon,wall-oblique,arm-deployed \
  --controllers switching --seeds 30 --first-seed 8128 --workers 2 --timeout 900 --out heldout_8128/gated
PYTHONPATH=/work/gate MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
  --controllers switching --seeds 30 --first-seed 8128 --workers 2 --timeout 900 \
  --ctl mode3.thrust_horizon=none --out heldout_8128/previous
