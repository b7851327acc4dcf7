#!/bin/sh
# experiments/heldout_current_9394 (README): run.sh OUT, at the declaring commit.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios thrusters-dead,wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 30 --first-seed 9394 --workers 1 --timeout 900 "$@" --out $out/$n
}
arm default & arm ungated --ctl observer.learning_acceleration=none; wait
