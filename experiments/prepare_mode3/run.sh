#!/bin/sh
# Part 1, ABBA: prepared/a, default/a, default/b, prepared/b (README). Run from experiments/prepare_mode3.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/prep MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out $arm/$name
}
part prepared 0 a --ctl prepare_mode3=true
part default 0 a
part default 12 b
part prepared 12 b --ctl prepare_mode3=true
