#!/bin/sh
# experiments/heldout_wide_9424 (README): run.sh OUT, at the declaring commit.
set -e
/work/main/.venv/bin/uvms campaign --scenarios thrusters-dead,wall-headon,wall-oblique,arm-deployed \
  --controllers switching --seeds 30 --first-seed 9424 --workers 2 --timeout 900 --mismatch wide --out $1
