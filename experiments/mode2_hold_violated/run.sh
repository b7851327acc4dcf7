#!/bin/sh
# Part 1, ABBA: hold/a, default/a, default/b, hold/b (README). Run from experiments/mode2_hold_violated.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/hold MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part hold 0 a --ctl mode2.hold_violated=0
part default 0 a
part default 12 b
part hold 12 b --ctl mode2.hold_violated=0
