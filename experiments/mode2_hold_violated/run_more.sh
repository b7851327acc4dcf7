#!/bin/sh
# Part 1, ABBA: hold/c, default/c, default/d, hold/d (README, part 1b). Run from experiments/mode2_hold_violated.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/hold MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part hold 24 c --ctl mode2.hold_violated=0
part default 24 c
part default 36 d
part hold 36 d --ctl mode2.hold_violated=0
