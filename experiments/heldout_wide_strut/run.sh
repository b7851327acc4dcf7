#!/bin/sh
# Both arms (README), one after the other. Run from experiments/heldout_wide_strut.
UVMS=/work/main/.venv/bin/uvms
for arm in strut nostrut; do
  extra=""; [ $arm = nostrut ] && extra="--ctl mode3.strut_weight=0"
  MUJOCO_GL=egl $UVMS campaign --scenarios thrusters-dead --controllers switching --seeds 30 --first-seed 8368 \
    --mismatch wide --workers 2 --timeout 900 $extra --out $arm
done
