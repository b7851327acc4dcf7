#!/bin/sh
# The probe's two arms, concurrently (no delay: deterministic). Run from experiments/mode3_strut_arm.
UVMS=/work/main/.venv/bin/uvms
arm() {  # name [--ctl ...]
  name=$1; shift
  PYTHONPATH=/work/strut MUJOCO_GL=egl $UVMS campaign --scenarios thrusters-dead --controllers switching \
    --seeds 40 --first-seed 0 --workers 1 --timeout 1800 --set duration=10 "$@" --out $name
}
arm strut --ctl mode3.strut_weight=1 &
arm default &
wait
