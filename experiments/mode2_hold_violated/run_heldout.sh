#!/bin/sh
# Part 4, ABBA then BAAB on fresh held-out seeds, then part 2 (README). Run from experiments/mode2_hold_violated.
set -e
UVMS=/work/main/.venv/bin/uvms
part() {  # arm first-seed part [--ctl ...]
  arm=$1; first=$2; name=$3; shift 3
  PYTHONPATH=/work/hold MUJOCO_GL=egl $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed \
    --controllers switching --seeds 12 --first-seed $first --workers 1 --timeout 900 \
    --latency 0.05:strict "$@" --out heldout/$arm/$name
}
part hold 8398 a --ctl mode2.hold_violated=0
part default 8398 a
part default 8410 b
part hold 8410 b --ctl mode2.hold_violated=0
part default 8422 c
part hold 8422 c --ctl mode2.hold_violated=0
part hold 8434 d --ctl mode2.hold_violated=0
part default 8434 d
FAM=thrusters-dead,wall-headon,wall-oblique,arm-deployed
for arm in hold default; do
  ctl=""; [ $arm = hold ] && ctl="--ctl mode2.hold_violated=0"
  PYTHONPATH=/work/hold MUJOCO_GL=egl $UVMS campaign --controllers switching --workers 2 --timeout 900 \
    --scenarios $FAM --seeds 40 --first-seed 0 $ctl --out nodelay/$arm
done
