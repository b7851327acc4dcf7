#!/bin/sh
# Part 2 (README), both arms: thrusters-dead 10 s and 5 s, the wall families 5 s. Run from experiments/mode3_strut_arm.
UVMS=/work/main/.venv/bin/uvms
camp() {  # out scenarios [args...]
  out=$1; scen=$2; shift 2
  PYTHONPATH=/work/strut MUJOCO_GL=egl $UVMS campaign --scenarios $scen --controllers switching \
    --seeds 30 --first-seed 8278 --workers 1 --timeout 1800 "$@" --out $out
}
( camp heldout_d10/strut thrusters-dead --set duration=10 --ctl mode3.strut_weight=1
  camp heldout_d5/strut thrusters-dead --ctl mode3.strut_weight=1
  camp heldout_walls/strut wall-headon,wall-oblique,arm-deployed --ctl mode3.strut_weight=1 ) &
( camp heldout_d10/default thrusters-dead --set duration=10
  camp heldout_d5/default thrusters-dead
  camp heldout_walls/default wall-headon,wall-oblique,arm-deployed ) &
wait
