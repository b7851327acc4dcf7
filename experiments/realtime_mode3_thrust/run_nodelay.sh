#!/bin/sh
# Part 3 (README). Run from experiments/realtime_mode3_thrust.
set -e
PYTHONPATH=/work/gate MUJOCO_GL=egl /work/main/.venv/bin/uvms campaign --scenarios thrusters-dead \
  --controllers switching --seeds 40 --first-seed 0 --workers 2 --timeout 900 \
  --ctl mode3.thrust_horizon=3 --out nodelay
