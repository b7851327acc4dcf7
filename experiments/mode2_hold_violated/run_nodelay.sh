#!/bin/sh
# Parts 2 and 3 (README). Run from experiments/mode2_hold_violated.
set -e
UVMS=/work/main/.venv/bin/uvms
run() {  # out [campaign options]
  out=$1; shift
  PYTHONPATH=/work/hold MUJOCO_GL=egl $UVMS campaign --controllers switching --workers 2 --timeout 900 "$@" --out $out
}
FAM=thrusters-dead,wall-headon,wall-oblique,arm-deployed
run wide/hold --scenarios thrusters-dead --seeds 40 --first-seed 100 --mismatch wide --ctl mode2.hold_violated=0
run wide/default --scenarios thrusters-dead --seeds 40 --first-seed 100 --mismatch wide
run nodelay/hold --scenarios $FAM --seeds 40 --first-seed 0 --ctl mode2.hold_violated=0
run nodelay/default --scenarios $FAM --seeds 40 --first-seed 0
