#!/bin/sh
# Part 3 (README), both arms: thrusters-dead 10 s on fresh seeds 8308-8367. Run from experiments/mode3_strut_arm.
UVMS=/work/main/.venv/bin/uvms
camp() {  # out [args...]
  out=$1; shift
  PYTHONPATH=/work/strut MUJOCO_GL=egl $UVMS campaign --scenarios thrusters-dead --controllers switching \
    --seeds 60 --first-seed 8308 --workers 1 --timeout 1800 --set duration=10 "$@" --out $out
}
camp heldout3_d10/strut --ctl mode3.strut_weight=1 &
camp heldout3_d10/default &
wait
