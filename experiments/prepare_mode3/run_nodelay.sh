#!/bin/sh
# Part 2 (README). Run from experiments/prepare_mode3.
set -e
UVMS=/work/main/.venv/bin/uvms
run() {  # out [campaign options]
  out=$1; shift
  PYTHONPATH=/work/prep MUJOCO_GL=egl $UVMS campaign --controllers switching --workers 2 --timeout 900 \
    --scenarios thrusters-dead,wall-headon,wall-oblique,arm-deployed --seeds 40 --first-seed 0 "$@" --out $out
}
run nodelay/prepared --ctl prepare_mode3=true
run nodelay/default
