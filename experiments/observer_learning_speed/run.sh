#!/bin/sh
# experiments/observer_learning_speed (README): run.sh OUT, at the declaring commit (no delay: the arms side by side).
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed,thrusters-dead --controllers switching \
    --seeds 24 --first-seed 0 --workers 1 --timeout 900 "$@" --out $out/$n
  $UVMS campaign --scenarios current-steady,current-gust --controllers switching --seeds 30 --first-seed 0 \
    --workers 1 --timeout 900 --mismatch wide "$@" --out $out/station/$n
}
arm gated --ctl observer.learning_speed=0.5 & arm default; wait
